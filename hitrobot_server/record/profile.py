"""What a ROS 2 MCAP file says about its channels: ``ros2msg`` schemas, QoS, the audit topic.

The message bytes are the CDR the Zenoh link produces (:class:`~hitrobot_server.bus.cdr.
Ros2Codec`), so a channel's schema is the ROS 2 definition of the same type, concatenated with
the definitions it uses as ROS 2 tools write them (rosbags generates the text).
"""

from __future__ import annotations

import yaml

from ..bus.cdr import Ros2Codec

PROFILE = "ros2"
ROS_DISTRO = "jazzy"  # the ROS 2 definitions our CDR follows (rosbags' Jazzy store)
AUDIT_TOPIC = "/hitrobot/audit"
AUDIT_TYPE = "hitrobot_msgs/msg/AuditEntry"  # schemas/hitrobot_msgs/msg/AuditEntry.msg

# The ros2 profile's required channel metadata: the offered QoS as a YAML sequence of policies
# (the MCAP registry's spelling); a latched topic is transient local, as ROS 2 latches.
_QOS = """- history: keep_last
  depth: {depth}
  reliability: reliable
  durability: {durability}
  deadline: {{sec: 0, nsec: 0}}
  lifespan: {{sec: 0, nsec: 0}}
  liveliness: automatic
  liveliness_lease_duration: {{sec: 0, nsec: 0}}
  avoid_ros_namespace_conventions: false
"""


def ros2_type_name(name: str) -> str:
    """``pkg/msg/Type`` (our registry's names are already so)."""
    pkg, *_, base = name.split("/")
    return f"{pkg}/msg/{base}"


def schema_text(codec: Ros2Codec, type_name: str) -> bytes:
    """The ``ros2msg`` schema data of a type: its definition, then each one it uses."""
    codec.type_hash(type_name)  # registers our own types in the ROS 2 store
    text, _md5 = codec.store.generate_msgdef(type_name, ros_version=2)
    return text.encode()


def channel_metadata(latched: bool) -> dict[str, str]:
    return {
        "offered_qos_profiles": _QOS.format(
            depth=1 if latched else 10, durability="transient_local" if latched else "volatile"),
        "latching": "1" if latched else "0",
    }


def is_latched(metadata: dict[str, str]) -> bool:
    """A latched (transient local) channel, by our key or by the QoS YAML (rosbag2 writes
    the durability as a name or as rmw's number, 1)."""
    if "latching" in metadata:
        return metadata["latching"] == "1"
    try:
        profiles = yaml.safe_load(metadata.get("offered_qos_profiles", "")) or []
    except yaml.YAMLError:
        return False
    return any(isinstance(p, dict) and p.get("durability") in (1, "transient_local")
               for p in profiles)

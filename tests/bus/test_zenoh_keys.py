"""rmw_zenoh's naming on Zenoh: data keys, liveliness tokens and sample attachments, checked
against examples from rmw_zenoh's design notes; and the default bus never loading Zenoh."""

from __future__ import annotations

import struct
import subprocess
import sys

import pytest

from hitrobot_server.bus.cdr import dds_type_name, ros_type_name
from hitrobot_server.bus.zenoh.keys import (
    NODE,
    PUBLISHER,
    SERVICE,
    data_key,
    pack_attachment,
    parse_token,
    qos_key,
    token,
    unpack_attachment,
)

# rmw_zenoh docs/design.md, "Topic and Service name mapping": the demo_nodes_cpp chatter key.
STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
# rmw_zenoh docs/design.md: 2/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/<hash>.
ADD_TWO_INTS_HASH = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"


def test_data_key_is_rmw_zenohs():
    assert data_key(0, "/chatter", "std_msgs/msg/String", STRING_HASH) == (
        f"0/chatter/std_msgs::msg::dds_::String_/{STRING_HASH}"
    )
    assert data_key(2, "/robot1/chatter", "std_msgs/msg/String", "H") == (
        "2/robot1/chatter/std_msgs::msg::dds_::String_/H"
    )
    assert dds_type_name("example_interfaces/srv/AddTwoInts") == (
        "example_interfaces::srv::dds_::AddTwoInts_"
    )
    assert ros_type_name("sensor_msgs::msg::dds_::LaserScan_") == "sensor_msgs/msg/LaserScan"
    assert ros_type_name("not a dds name") is None


def test_liveliness_tokens_round_trip():
    key = token(0, "abc", 3, 12, PUBLISHER, "/talker", "/robot1/chatter",
                type_name="std_msgs/msg/String", type_hash=STRING_HASH, qos=qos_key(True, 1))
    assert key == (
        "@ros2_lv/0/abc/3/12/MP/%/%/talker/%robot1%chatter/std_msgs::msg::dds_::String_/"
        f"{STRING_HASH}/:1:,1:,:,:,,"
    )
    e = parse_token(key)
    assert (e.zid, e.kind, e.node, e.name) == ("abc", PUBLISHER, "/talker", "/robot1/chatter")
    assert e.type_name == "std_msgs/msg/String" and e.latched
    node = token(0, "abc", 3, 3, NODE, "/ns/sub/worker")
    assert node == "@ros2_lv/0/abc/3/3/NN/%/%ns%sub/worker"
    assert parse_token(node).node == "/ns/sub/worker"
    assert not parse_token(token(0, "z", 1, 2, SERVICE, "/n", "/s", "std_srvs/srv/Empty", "H",
                                 qos_key())).latched
    # rmw_zenoh's own default-QoS token for a service server parses too
    ros = ("@ros2_lv/2/f9980ee0495eaafb3e38f0d19e2eae12/0/10/SS/%/%/add_two_ints_server/"
           f"%add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/{ADD_TWO_INTS_HASH}/"
           "::,10:,:,:,,")
    e = parse_token(ros)
    assert (e.kind, e.node, e.name) == (SERVICE, "/add_two_ints_server", "/add_two_ints")
    assert e.type_name == "example_interfaces/srv/AddTwoInts" and not e.latched
    assert parse_token("@ros2_lv/0/abc") is None
    assert parse_token("0/chatter/std_msgs::msg::dds_::String_/H") is None


def test_attachment_layout():
    gid = bytes(range(16))
    raw = pack_attachment(7, 1_700_000_000_123_456_789, gid)
    assert raw == struct.pack("<qq", 7, 1_700_000_000_123_456_789) + b"\x10" + gid
    assert unpack_attachment(raw) == (7, 1_700_000_000_123_456_789, gid)
    with pytest.raises(ValueError):
        unpack_attachment(raw[:-1])
    with pytest.raises(ValueError):
        pack_attachment(1, 2, b"short")


def test_local_bus_never_imports_zenoh():
    """The default in-process bus runs with no Zenoh import at all."""
    code = (
        "import asyncio, sys\n"
        "from hitrobot_server.config import Settings\n"
        "from hitrobot_server.server import HitrobotServer\n"
        "async def main():\n"
        "    s = HitrobotServer(Settings.of(port=0, tcp_port=0, robot='none'))\n"
        "    await s.start(); await s.stop()\n"
        "asyncio.run(main())\n"
        "print('zenoh' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False"

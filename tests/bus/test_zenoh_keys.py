"""rmw_zenoh naming (keys, liveliness tokens, attachments) and ROS 2 CDR/type hashes, checked
against values computed outside this project: hashes published by ROS 2 (rmw_zenoh's design
notes) and CDR bytes built by hand with struct."""

from __future__ import annotations

import struct
import subprocess
import sys

import pytest

from hitrobot_server.bus.cdr import Ros2Codec, dds_type_name, ros_type_name
from hitrobot_server.bus.zenoh_keys import (
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
from hitrobot_server.types.registry import TypeRegistry

# rmw_zenoh docs/design.md, "Topic and Service name mapping": the demo_nodes_cpp chatter key.
STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
# rmw_zenoh docs/design.md: 2/add_two_ints/example_interfaces::srv::dds_::AddTwoInts_/<hash>.
ADD_TWO_INTS_HASH = "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
# geometry_msgs/msg/TwistStamped as a public rmw_zenoh web client keys it (ROS 2 Jazzy).
TWIST_STAMPED_HASH = "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64"


@pytest.fixture(scope="module")
def codec() -> Ros2Codec:
    return Ros2Codec(TypeRegistry.default())


def test_message_hashes_match_ros2(codec):
    assert codec.type_hash("std_msgs/msg/String") == STRING_HASH
    assert codec.type_hash("geometry_msgs/msg/TwistStamped") == TWIST_STAMPED_HASH


def test_service_hash_matches_ros2(tmp_path):
    srv = tmp_path / "example_interfaces" / "srv"
    srv.mkdir(parents=True)
    (srv / "AddTwoInts.srv").write_text("int64 a\nint64 b\n---\nint64 sum\n")
    codec = Ros2Codec(TypeRegistry([tmp_path]))
    assert codec.service_hash("example_interfaces/srv/AddTwoInts") == ADD_TWO_INTS_HASH


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


def cdr_string(text: str) -> bytes:
    raw = text.encode() + b"\0"
    return b"\x00\x01\x00\x00" + struct.pack("<I", len(raw)) + raw


def test_cdr_string_bytes(codec):
    reg = TypeRegistry.default()
    mtype = reg.msg("std_msgs/String")
    assert codec.encode({"data": "hello"}, mtype) == cdr_string("hello")
    assert codec.decode(cdr_string("world"), mtype) == {"data": "world"}


def test_cdr_header_is_ros2s(codec):
    """ROS 2's Header: no seq; stamp as int32 sec + uint32 nanosec; then frame_id."""
    reg = TypeRegistry.default()
    mtype = reg.msg("geometry_msgs/PointStamped")
    msg = {
        "header": {"seq": 77, "stamp": {"secs": 5, "nsecs": 6}, "frame_id": "map"},
        "point": {"x": 1.0, "y": 2.0, "z": 3.0},
    }
    frame = b"map\0"
    body = struct.pack("<iiI", 5, 6, len(frame)) + frame  # 16 bytes: doubles start aligned
    body += struct.pack("<ddd", 1.0, 2.0, 3.0)
    expected = b"\x00\x01\x00\x00" + body
    assert codec.encode(msg, mtype) == expected
    back = codec.decode(expected, mtype)
    assert back["header"] == {"seq": 0, "stamp": {"secs": 5, "nsecs": 6}, "frame_id": "map"}
    assert back["point"] == msg["point"]


def test_cdr_round_trip_of_our_own_types(codec):
    reg = TypeRegistry.default()
    scan = reg.msg("sensor_msgs/LaserScan")
    msg = {
        "header": {"seq": 1, "stamp": {"secs": 1, "nsecs": 2}, "frame_id": "laser"},
        "angle_min": -1.5, "angle_max": 1.5, "angle_increment": 0.5, "time_increment": 0.0,
        "scan_time": 0.125, "range_min": 0.25, "range_max": 8.0,
        "ranges": [1.0, 2.5, 4.0], "intensities": [],
    }
    back = codec.decode(codec.encode(msg, scan), scan)
    assert back["ranges"] == [1.0, 2.5, 4.0] and back["scan_time"] == 0.125
    grid = reg.msg("nav_msgs/OccupancyGrid")
    data = list(range(-1, 99))
    g = codec.decode(codec.encode({"info": {"width": 10, "height": 10}, "data": data}, grid), grid)
    assert g["data"] == data and g["info"]["width"] == 10
    state = reg.msg("slamware_ros_sdk/RobotBasicState")
    s = codec.decode(codec.encode({"battery_percentage": 42, "is_charging": True}, state), state)
    assert s["battery_percentage"] == 42 and s["is_charging"] is True
    assert codec.type_hash(state.name).startswith("RIHS01_")


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
        "    s = HitrobotServer(Settings(port=0, tcp_port=0, robot='none'))\n"
        "    await s.start(); await s.stop()\n"
        "asyncio.run(main())\n"
        "print('zenoh' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False"

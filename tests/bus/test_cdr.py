"""ROS 2 CDR and RIHS01 type hashes of our types, checked against values computed outside this
project: hashes ROS 2 publishes and CDR bytes built by hand with struct."""

from __future__ import annotations

import struct

import pytest

from hitrobot_server.bus.cdr import Ros2Codec
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

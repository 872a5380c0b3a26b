"""cbor-raw: ROS 1 wire bytes that rosbags deserialises back to the same values."""

from __future__ import annotations

import struct

import cbor2
import numpy as np
import pytest

from hitrobot_server.protocol.rawmsg import encode_publish_cbor_raw, serialize_ros1
from hitrobot_server.types.convert import default_message, from_json
from hitrobot_server.types.registry import TypeRegistry

NOW = (1700000000, 5)


@pytest.fixture(scope="module")
def reg() -> TypeRegistry:
    return TypeRegistry.default()


def canonical(reg: TypeRegistry, name: str, value: dict) -> dict:
    return from_json(reg.msg(name), value, reg, now=lambda: NOW)[0]


def test_header_and_string_wire_layout(reg: TypeRegistry) -> None:
    mtype = reg.msg("std_msgs/Header")
    raw = serialize_ros1(
        {"seq": 7, "stamp": {"secs": 1, "nsecs": 2}, "frame_id": "map"}, mtype, reg
    )
    assert raw == struct.pack("<IiII", 7, 1, 2, 3) + b"map"


def test_laser_scan_round_trip(reg: TypeRegistry) -> None:
    mtype = reg.msg("sensor_msgs/LaserScan")
    ranges = [0.5 * i for i in range(10)]
    msg = canonical(
        reg,
        "sensor_msgs/LaserScan",
        {"header": {"frame_id": "laser", "seq": 2}, "angle_min": -1.5, "ranges": ranges},
    )
    back = reg.typestore.deserialize_ros1(serialize_ros1(msg, mtype, reg), mtype.name)
    assert back.header.frame_id == "laser" and back.header.seq == 2
    assert (back.header.stamp.sec, back.header.stamp.nanosec) == NOW
    assert back.angle_min == pytest.approx(-1.5)
    assert back.ranges.dtype == np.float32 and back.ranges.tolist() == ranges
    assert back.intensities.tolist() == []


def test_occupancy_grid_and_fixed_arrays(reg: TypeRegistry) -> None:
    grid = reg.msg("nav_msgs/OccupancyGrid")
    cells = [-1, 0, 100, 7]
    msg = canonical(
        reg,
        "nav_msgs/OccupancyGrid",
        {"info": {"width": 2, "height": 2, "resolution": 0.05}, "data": cells},
    )
    back = reg.typestore.deserialize_ros1(serialize_ros1(msg, grid, reg), grid.name)
    assert back.data.tolist() == cells and back.info.width == 2
    assert back.info.resolution == pytest.approx(0.05)

    cov_type = reg.msg("geometry_msgs/PoseWithCovariance")
    cov = [float(i) for i in range(36)]
    msg = canonical(reg, "geometry_msgs/PoseWithCovariance", {"covariance": cov})
    back = reg.typestore.deserialize_ros1(serialize_ros1(msg, cov_type, reg), cov_type.name)
    assert back.covariance.tolist() == cov


def test_bytes_strings_and_message_arrays(reg: TypeRegistry) -> None:
    image = reg.msg("sensor_msgs/Image")
    msg = default_message(image, reg) | {"encoding": "mono8", "width": 3, "data": b"\x01\x02\x03"}
    back = reg.typestore.deserialize_ros1(serialize_ros1(msg, image, reg), image.name)
    assert back.encoding == "mono8" and bytes(back.data) == b"\x01\x02\x03"

    tf = reg.msg("tf2_msgs/TFMessage")
    msg = canonical(
        reg,
        "tf2_msgs/TFMessage",
        {"transforms": [{"child_frame_id": "base", "transform": {"translation": {"x": 2}}}]},
    )
    back = reg.typestore.deserialize_ros1(serialize_ros1(msg, tf, reg), tf.name)
    assert back.transforms[0].child_frame_id == "base"
    assert back.transforms[0].transform.translation.x == 2.0

    joints = reg.msg("sensor_msgs/JointState")
    msg = canonical(reg, "sensor_msgs/JointState", {"name": ["j1", "j2"], "position": [1, 2]})
    msg["velocity"] = np.array([0.5, 0.25])
    back = reg.typestore.deserialize_ros1(serialize_ros1(msg, joints, reg), joints.name)
    assert back.name == ["j1", "j2"] and back.velocity.tolist() == [0.5, 0.25]


def test_service_and_action_parts(reg: TypeRegistry) -> None:
    empty = reg.srv("std_srvs/Empty").request
    assert serialize_ros1({}, empty, reg) == b""
    trigger = reg.srv("std_srvs/Trigger").response
    raw = serialize_ros1({"success": True, "message": "ok"}, trigger, reg)
    assert raw == b"\x01" + struct.pack("<I", 2) + b"ok"
    feedback = reg.action("nav2_msgs/NavigateToPose").feedback
    msg = canonical(reg, feedback.name, {"navigation_time": -1.5, "number_of_recoveries": 3})
    back = reg.typestore.deserialize_ros1(serialize_ros1(msg, feedback, reg), feedback.name)
    assert (back.navigation_time.sec, back.navigation_time.nanosec) == (-2, 500_000_000)
    assert back.number_of_recoveries == 3


def test_bool_and_char_arrays(tmp_path) -> None:
    (tmp_path / "kitchen_msgs" / "msg").mkdir(parents=True)
    (tmp_path / "kitchen_msgs" / "msg" / "Sink.msg").write_text(
        "bool[] flags\nchar[] text\nchar[2] code\nbyte b\nchar c\ntime[] stamps\n"
    )
    reg = TypeRegistry([tmp_path])
    mtype = reg.msg("kitchen_msgs/Sink")
    msg = {
        "flags": [True, False],
        "text": b"hey",
        "code": b"ok",
        "b": -3,
        "c": 200,
        "stamps": [{"secs": 4, "nsecs": 5}],
    }
    raw = serialize_ros1(msg, mtype, reg)
    assert raw[:6] == struct.pack("<I", 2) + b"\x01\x00"
    back = reg.typestore.deserialize_ros1(raw, mtype.name)
    assert back.flags.tolist() == [True, False]
    assert bytes(back.text) == b"hey" and bytes(back.code) == b"ok"
    assert (back.b, back.c) == (-3, 200)
    assert (back.stamps[0].sec, back.stamps[0].nanosec) == (4, 5)


def test_publish_frame(reg: TypeRegistry) -> None:
    mtype = reg.msg("std_msgs/String")
    frame = cbor2.loads(encode_publish_cbor_raw("/chatter", {"data": "hi"}, mtype, reg, (12, 34)))
    assert frame == {
        "op": "publish",
        "topic": "/chatter",
        "msg": {"secs": 12, "nsecs": 34, "bytes": struct.pack("<I", 2) + b"hi"},
    }

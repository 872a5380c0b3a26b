"""cbor compression: type-directed values, RFC 8746 typed-array tags, numpy input."""

from __future__ import annotations

import math
import struct
import tracemalloc

import cbor2
import numpy as np
import pytest

from hitrobot_server.protocol.cbor import (
    _TAG_DTYPES,
    decode,
    decode_typed_arrays,
    encode_publish_cbor,
    to_cbor_value,
)
from hitrobot_server.types.convert import default_message, from_json
from hitrobot_server.types.jsoncodec import InvalidValue
from hitrobot_server.types.registry import TypeRegistry

NOW = (1700000000, 5)


@pytest.fixture(scope="module")
def reg() -> TypeRegistry:
    return TypeRegistry.default()


def canonical(reg: TypeRegistry, name: str, value: dict) -> dict:
    return from_json(reg.msg(name), value, reg, now=lambda: NOW)[0]


@pytest.mark.parametrize(
    ("msg_type", "tag", "fmt", "values"),
    [
        ("std_msgs/UInt16MultiArray", 69, "<H", [0, 1, 65535]),
        ("std_msgs/UInt32MultiArray", 70, "<I", [0, 2**32 - 1]),
        ("std_msgs/UInt64MultiArray", 71, "<Q", [0, 2**64 - 1]),
        ("std_msgs/Int8MultiArray", 72, "<b", [-128, 0, 127]),
        ("std_msgs/ByteMultiArray", 72, "<b", [-1, 5]),
        ("std_msgs/Int16MultiArray", 77, "<h", [-32768, 32767]),
        ("std_msgs/Int32MultiArray", 78, "<i", [-(2**31), 7]),
        ("std_msgs/Int64MultiArray", 79, "<q", [-(2**63), 2**63 - 1]),
        ("std_msgs/Float32MultiArray", 85, "<f", [1.5, -2.25]),
        ("std_msgs/Float64MultiArray", 86, "<d", [0.1, 1e300]),
    ],
)
def test_typed_array_tags(
    reg: TypeRegistry, msg_type: str, tag: int, fmt: str, values: list
) -> None:
    mtype = reg.msg(msg_type)
    msg = canonical(reg, msg_type, {"data": values})
    data = to_cbor_value(msg, mtype, reg)["data"]
    assert isinstance(data, cbor2.CBORTag) and data.tag == tag
    assert data.value == b"".join(struct.pack(fmt, v) for v in values)
    raw = cbor2.loads(encode_publish_cbor("/t", msg, mtype, reg))
    assert raw["msg"]["data"].tag == tag
    decoded = decode(encode_publish_cbor("/t", msg, mtype, reg))["msg"]["data"]
    assert isinstance(decoded, np.ndarray) and decoded.tolist() == values


def test_publish_frame_layout(reg: TypeRegistry) -> None:
    mtype = reg.msg("geometry_msgs/Twist")
    msg = canonical(reg, "geometry_msgs/Twist", {"linear": {"x": 1}})
    frame = cbor2.loads(encode_publish_cbor("/cmd_vel", msg, mtype, reg))
    assert frame == {
        "op": "publish",
        "topic": "/cmd_vel",
        "msg": {
            "linear": {"x": 1.0, "y": 0.0, "z": 0.0},
            "angular": {"x": 0.0, "y": 0.0, "z": 0.0},
        },
    }


def test_scalars_time_strings_and_bools(reg: TypeRegistry) -> None:
    mtype = reg.msg("sensor_msgs/JointState")
    msg = canonical(
        reg,
        "sensor_msgs/JointState",
        {"header": {"seq": 3, "frame_id": "base"}, "name": ["a", "b"], "position": [1.0, 2.0]},
    )
    value = cbor2.loads(cbor2.dumps(to_cbor_value(msg, mtype, reg)))
    assert value["header"] == {
        "seq": 3,
        "stamp": {"secs": NOW[0], "nsecs": NOW[1]},
        "frame_id": "base",
    }
    assert value["name"] == ["a", "b"]
    assert value["position"] == cbor2.CBORTag(86, struct.pack("<2d", 1.0, 2.0))
    assert value["velocity"] == cbor2.CBORTag(86, b"")
    flags = reg.msg("diagnostic_msgs/KeyValue")
    assert to_cbor_value({"key": "k", "value": "v"}, flags, reg) == {"key": "k", "value": "v"}


def test_fixed_size_float64_covariance(reg: TypeRegistry) -> None:
    mtype = reg.msg("geometry_msgs/PoseWithCovarianceStamped")
    cov = [float(i) / 3 for i in range(36)]
    msg = canonical(reg, "geometry_msgs/PoseWithCovarianceStamped", {"pose": {"covariance": cov}})
    tagged = to_cbor_value(msg, mtype, reg)["pose"]["covariance"]
    assert tagged.tag == 86 and len(tagged.value) == 36 * 8
    decoded = decode(encode_publish_cbor("/amcl_pose", msg, mtype, reg))
    assert decoded["msg"]["pose"]["covariance"].tolist() == cov
    assert decoded["msg"]["pose"]["pose"]["orientation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}


def test_occupancy_grid_int8_data(reg: TypeRegistry) -> None:
    mtype = reg.msg("nav_msgs/OccupancyGrid")
    cells = [-1, 0, 100, 42] * 50
    msg = canonical(
        reg, "nav_msgs/OccupancyGrid", {"info": {"width": 20, "height": 10}, "data": cells}
    )
    value = to_cbor_value(msg, mtype, reg)
    assert value["data"].tag == 72 and value["data"].value == bytes(c & 0xFF for c in cells)
    decoded = decode(encode_publish_cbor("/map", msg, mtype, reg))["msg"]
    assert decoded["data"].tolist() == cells
    assert decoded["info"]["width"] == 20
    assert decoded["info"]["map_load_time"] == {"secs": 0, "nsecs": 0}


def test_byte_arrays_are_plain_byte_strings(reg: TypeRegistry) -> None:
    image = reg.msg("sensor_msgs/Image")
    msg = default_message(image, reg) | {"data": b"\x00\x01\xff"}
    assert to_cbor_value(msg, image, reg)["data"] == b"\x00\x01\xff"
    msg["data"] = np.array([3, 4], dtype=np.uint8)
    assert to_cbor_value(msg, image, reg)["data"] == b"\x03\x04"
    msg["data"] = [5, 6]
    assert to_cbor_value(msg, image, reg)["data"] == b"\x05\x06"
    uuid = reg.msg("unique_identifier_msgs/UUID")
    frame = cbor2.loads(encode_publish_cbor("/u", {"uuid": bytes(range(16))}, uuid, reg))
    assert frame["msg"]["uuid"] == bytes(range(16))


KITCHEN = """\
bool[] flags
bool[2] pair
char[] text
char[3] code
int32[4] quad
string[] words
time[] stamps
duration[2] spans
"""


@pytest.fixture(scope="module")
def kitchen(tmp_path_factory: pytest.TempPathFactory) -> TypeRegistry:
    root = tmp_path_factory.mktemp("schemas")
    (root / "kitchen_msgs" / "msg").mkdir(parents=True)
    (root / "kitchen_msgs" / "msg" / "Sink.msg").write_text(KITCHEN)
    return TypeRegistry([root])


def test_bool_char_string_and_time_arrays(kitchen: TypeRegistry) -> None:
    mtype = kitchen.msg("kitchen_msgs/Sink")
    msg = from_json(
        mtype,
        {
            "flags": [True, False, True],
            "pair": [False, True],
            "text": "aGk=",
            "code": [65, 66, 67],
            "quad": [1, -2, 3, -4],
            "words": ["x", "y"],
            "stamps": [{"secs": 1, "nsecs": 2}],
            "spans": [0.5, -1],
        },
        kitchen,
    )[0]
    value = to_cbor_value(msg, mtype, kitchen)
    assert value["flags"] == [True, False, True] and value["pair"] == [False, True]
    assert value["text"] == b"hi" and value["code"] == b"ABC"
    assert value["quad"] == cbor2.CBORTag(78, struct.pack("<4i", 1, -2, 3, -4))
    assert value["words"] == ["x", "y"]
    assert value["stamps"] == [{"secs": 1, "nsecs": 2}]
    assert value["spans"] == [{"secs": 0, "nsecs": 500_000_000}, {"secs": -1, "nsecs": 0}]
    msg["flags"] = np.array([True, False])
    assert to_cbor_value(msg, mtype, kitchen)["flags"] == [True, False]


def test_numpy_inputs_and_nan(reg: TypeRegistry) -> None:
    scan = reg.msg("sensor_msgs/LaserScan")
    msg = default_message(scan, reg)
    msg["ranges"] = np.array([1.0, np.nan, np.inf], dtype=np.float64)
    msg["range_max"] = np.float32(20.0)
    msg["header"]["seq"] = np.uint32(9)
    value = to_cbor_value(msg, scan, reg)
    assert value["ranges"].tag == 85
    assert value["range_max"] == 20.0 and type(value["range_max"]) is float
    assert type(value["header"]["seq"]) is int
    decoded = decode(cbor2.dumps(value))
    assert decoded["ranges"][0] == 1.0
    assert math.isnan(decoded["ranges"][1]) and decoded["ranges"][2] == math.inf


def test_arrays_of_messages(reg: TypeRegistry) -> None:
    path = reg.msg("nav_msgs/Path")
    msg = canonical(
        reg, "nav_msgs/Path", {"poses": [{"pose": {"position": {"x": 1}}}, {"pose": {}}]}
    )
    decoded = decode(encode_publish_cbor("/plan", msg, path, reg))["msg"]
    assert len(decoded["poses"]) == 2
    assert decoded["poses"][0]["pose"]["position"]["x"] == 1.0
    assert decoded["poses"][1]["header"]["stamp"] == {"secs": NOW[0], "nsecs": NOW[1]}


def test_decode_typed_arrays_other_tags() -> None:
    big_endian = cbor2.CBORTag(82, struct.pack(">2d", 1.0, 2.0))
    unrelated = cbor2.CBORTag(1, 12345)
    decoded = decode_typed_arrays({"a": [big_endian], "b": unrelated, "c": 1})
    assert decoded["a"][0].dtype.isnative and decoded["a"][0].tolist() == [1.0, 2.0]
    assert decoded["b"] is unrelated and decoded["c"] == 1
    assert decode_typed_arrays(cbor2.CBORTag(64, b"\x01\x02")).tolist() == [1, 2]


@pytest.mark.parametrize("tag", sorted(_TAG_DTYPES))
def test_typed_arrays_take_no_more_memory_than_their_bytes(tag: int) -> None:
    """The typed-array bomb: 1 MB under tag 72 was one Python int per byte (56x the frame)."""
    payload = bytes(range(256)) * 4096  # 1 MiB, a whole number of items for every width
    frame = cbor2.dumps({"op": "publish", "topic": "/t", "msg": {"data": cbor2.CBORTag(
        tag, payload)}})
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        decoded = decode(frame)
        held = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    array = decoded["msg"]["data"]
    assert isinstance(array, np.ndarray) and array.nbytes == len(payload)
    assert held <= 2 * len(payload) + 64 * 1024


def test_a_typed_array_of_partial_items_is_refused() -> None:
    frame = cbor2.dumps({"op": "publish", "id": "p", "topic": "/t",
                         "msg": {"data": cbor2.CBORTag(86, b"\x00" * 9)}})
    with pytest.raises(InvalidValue, match="not a whole number of 8-byte items") as info:
        decode(frame)
    assert info.value.id == "p"


@pytest.mark.parametrize(
    ("value", "needle"),
    [
        ({"id": "c", "msg": {"a": 2**64}}, "field 'msg.a' is an integer outside the 64-bit range"),
        ({"id": "c", "msg": {"a": cbor2.CBORTag(4242, 1)}}, "unsupported type (CBORTag)"),
        ({"id": "c", "msg": {"a": cbor2.undefined}}, "unsupported type"),
        ({"id": "c", "msg": {5: 1}}, "has a key"),
    ],
)
def test_decode_refuses_values_json_cannot_carry(value, needle):
    with pytest.raises(InvalidValue) as info:
        decode(cbor2.dumps(value))
    assert needle in str(info.value) and info.value.id == "c"


def test_decode_keeps_bytes_and_typed_arrays():
    got = decode(cbor2.dumps({"raw": b"\x01\x02", "big": 2**64 - 1}))
    assert got == {"raw": b"\x01\x02", "big": 2**64 - 1}

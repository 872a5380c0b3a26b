"""JSON → canonical message conversion: happy paths, every error class, defaults, headers."""

from __future__ import annotations

import base64
import math
import time

import numpy as np
import pytest

from hitrobot_server.types.convert import ConversionError, default_message, from_json, wall_now
from hitrobot_server.types.registry import TypeRegistry

NOW = (1700000000, 123456789)
NOW_DICT = {"secs": NOW[0], "nsecs": NOW[1]}


@pytest.fixture(scope="module")
def reg() -> TypeRegistry:
    return TypeRegistry.default()


def convert(reg: TypeRegistry, name: str, value: object) -> tuple[dict, list[str]]:
    return from_json(reg.msg(name), value, reg, now=lambda: NOW)


def error(reg: TypeRegistry, name: str, value: object) -> str:
    with pytest.raises(ConversionError) as info:
        convert(reg, name, value)
    return str(info.value)


# --- happy paths ---------------------------------------------------------------------------


def test_twist_full(reg: TypeRegistry) -> None:
    value = {"linear": {"x": 0.5, "y": 0, "z": -1}, "angular": {"x": 0.0, "y": 0.0, "z": 1.25}}
    msg, missing = convert(reg, "geometry_msgs/Twist", value)
    assert msg == {"linear": {"x": 0.5, "y": 0.0, "z": -1.0}, "angular": value["angular"]}
    assert all(type(v) is float for v in msg["linear"].values())
    assert missing == []


def test_none_means_empty_message(reg: TypeRegistry) -> None:
    msg, missing = convert(reg, "std_msgs/String", None)
    assert msg == {"data": ""}
    assert missing == ["data"]


def test_scalars_of_every_kind(reg: TypeRegistry) -> None:
    assert convert(reg, "std_msgs/Bool", {"data": True})[0] == {"data": True}
    assert convert(reg, "std_msgs/String", {"data": "hé"})[0] == {"data": "hé"}
    assert convert(reg, "std_msgs/Int8", {"data": -128})[0] == {"data": -128}
    assert convert(reg, "std_msgs/UInt64", {"data": 2**64 - 1})[0] == {"data": 2**64 - 1}
    assert convert(reg, "std_msgs/Char", {"data": 255})[0] == {"data": 255}
    assert convert(reg, "std_msgs/Byte", {"data": -1})[0] == {"data": -1}


def test_integral_float_accepted_for_int(reg: TypeRegistry) -> None:
    msg, _ = convert(reg, "std_msgs/Int32", {"data": 3.0})
    assert msg == {"data": 3} and type(msg["data"]) is int
    msg, _ = convert(reg, "std_msgs/Int32MultiArray", {"data": [1, 2.0, 3]})
    assert msg["data"] == [1, 2, 3] and all(type(x) is int for x in msg["data"])


def test_null_float_is_nan(reg: TypeRegistry) -> None:
    msg, _ = convert(reg, "std_msgs/Float64", {"data": None})
    assert math.isnan(msg["data"])
    msg, _ = convert(reg, "std_msgs/Float32MultiArray", {"data": [1, None, 2.5]})
    assert msg["data"][0] == 1.0 and math.isnan(msg["data"][1]) and msg["data"][2] == 2.5


def test_byte_arrays_from_base64_and_lists(reg: TypeRegistry) -> None:
    raw = bytes(range(256))
    b64 = base64.b64encode(raw).decode()
    msg, _ = convert(reg, "std_msgs/UInt8MultiArray", {"data": b64})
    assert msg["data"] == raw
    msg, _ = convert(reg, "std_msgs/UInt8MultiArray", {"data": [0, 7, 255]})
    assert msg["data"] == b"\x00\x07\xff"
    msg, _ = convert(reg, "std_msgs/UInt8MultiArray", {"data": [1.0, 2]})
    assert msg["data"] == b"\x01\x02"
    msg, _ = convert(reg, "std_msgs/UInt8MultiArray", {"data": b"\x01"})
    assert msg["data"] == b"\x01"
    uuid = list(range(16))
    msg, _ = convert(reg, "unique_identifier_msgs/UUID", {"uuid": uuid})
    assert msg["uuid"] == bytes(uuid)


def test_int8_arrays_are_lists(reg: TypeRegistry) -> None:
    grid = {"info": {"width": 2, "height": 2}, "data": [-1, 0, 100, 50]}
    msg, missing = convert(reg, "nav_msgs/OccupancyGrid", grid)
    assert msg["data"] == [-1, 0, 100, 50]
    assert msg["info"]["width"] == 2 and msg["info"]["resolution"] == 0.0
    assert "info.resolution" in missing and "info.origin" in missing


def test_string_and_bool_and_message_arrays(reg: TypeRegistry) -> None:
    value = {
        "name": ["a", "b"],
        "position": [1, 2.5],
        "velocity": [],
        "effort": [],
        "header": {"frame_id": "base"},
    }
    msg, missing = convert(reg, "sensor_msgs/JointState", value)
    assert msg["name"] == ["a", "b"] and msg["position"] == [1.0, 2.5]
    assert missing == []
    arr = {"markers": [{"ns": "x", "points": [{"x": 1}]}, {}]}
    msg, missing = convert(reg, "visualization_msgs/MarkerArray", arr)
    assert msg["markers"][0]["points"] == [{"x": 1.0, "y": 0.0, "z": 0.0}]
    assert msg["markers"][1]["ns"] == ""
    assert "markers[0].points[0].y" in missing and "markers[1].ns" in missing
    assert msg["markers"][1]["header"]["stamp"] == NOW_DICT


def test_char_bool_string_and_time_arrays(tmp_path) -> None:
    (tmp_path / "kitchen_msgs" / "msg").mkdir(parents=True)
    (tmp_path / "kitchen_msgs" / "msg" / "Sink.msg").write_text(
        "bool[] flags\nchar[] text\nchar[2] code\nstring[2] pair\ntime[] stamps\n"
    )
    reg = TypeRegistry([tmp_path])
    mtype = reg.msg("kitchen_msgs/Sink")
    value = {"flags": [True], "text": "aGk=", "code": [1, 2], "pair": ["a", "b"], "stamps": [3]}
    msg, missing = from_json(mtype, value, reg)
    assert msg == {
        "flags": [True],
        "text": b"hi",
        "code": b"\x01\x02",
        "pair": ["a", "b"],
        "stamps": [{"secs": 3, "nsecs": 0}],
    }
    assert missing == []
    assert default_message(mtype, reg) == {
        "flags": [],
        "text": b"",
        "code": b"\x00\x00",
        "pair": ["", ""],
        "stamps": [],
    }
    with pytest.raises(ConversionError, match=r"field 'flags\[1\]' must be a boolean, got integer"):
        from_json(mtype, {"flags": [True, 1]}, reg)
    with pytest.raises(ConversionError, match=r"field 'pair' must have exactly 2 elements, got 1"):
        from_json(mtype, {"pair": ["a"]}, reg)
    with pytest.raises(ConversionError, match=r"field 'stamps\[0\]' must be a time"):
        from_json(mtype, {"stamps": ["soon"]}, reg)


def test_fixed_arrays(reg: TypeRegistry) -> None:
    cov = [float(i) for i in range(36)]
    msg, _ = convert(reg, "geometry_msgs/PoseWithCovariance", {"covariance": cov})
    assert msg["covariance"] == cov
    msg, missing = convert(reg, "geometry_msgs/PoseWithCovariance", {})
    assert msg["covariance"] == [0.0] * 36
    assert missing == ["pose", "covariance"]


@pytest.mark.parametrize(
    ("given", "expected"),
    [
        ({"secs": 5, "nsecs": 6}, {"secs": 5, "nsecs": 6}),
        ({"sec": 5, "nanosec": 6}, {"secs": 5, "nsecs": 6}),
        ({"sec": 5, "nsec": 6}, {"secs": 5, "nsecs": 6}),
        ({"secs": 5, "nsecs": 1_500_000_000}, {"secs": 6, "nsecs": 500_000_000}),
        (12.25, {"secs": 12, "nsecs": 250_000_000}),
        (7, {"secs": 7, "nsecs": 0}),
        ("now", NOW_DICT),
    ],
)
def test_time_spellings(reg: TypeRegistry, given: object, expected: dict) -> None:
    msg, missing = convert(reg, "std_msgs/Time", {"data": given})
    assert msg == {"data": expected}
    assert missing == []


def test_negative_duration_is_normalised(reg: TypeRegistry) -> None:
    msg, _ = convert(reg, "std_msgs/Duration", {"data": -1.5})
    assert msg["data"] == {"secs": -2, "nsecs": 500_000_000}
    msg, _ = convert(reg, "std_msgs/Duration", {"data": {"secs": 0, "nsecs": -1}})
    assert msg["data"] == {"secs": -1, "nsecs": 999_999_999}


def test_partial_time_reports_missing_part(reg: TypeRegistry) -> None:
    msg, missing = convert(reg, "std_msgs/Time", {"data": {"secs": 3}})
    assert msg["data"] == {"secs": 3, "nsecs": 0}
    assert missing == ["data.nsecs"]


def test_default_now_is_wall_clock(reg: TypeRegistry) -> None:
    before = time.time()
    msg, _ = from_json(reg.msg("std_msgs/Time"), {"data": "now"}, reg)
    stamp = msg["data"]["secs"] + msg["data"]["nsecs"] / 1e9
    assert before - 1 <= stamp <= time.time() + 1
    secs, nsecs = wall_now()
    assert type(secs) is int and 0 <= nsecs < 1_000_000_000


def test_output_does_not_alias_input_lists(reg: TypeRegistry) -> None:
    data = [1.0, 2.0]
    msg, _ = convert(reg, "std_msgs/Float64MultiArray", {"data": data})
    data.append(3.0)
    assert msg["data"] == [1.0, 2.0]


# --- header auto-fill ----------------------------------------------------------------------


def test_header_omitted_is_filled_and_not_missing(reg: TypeRegistry) -> None:
    msg, missing = convert(reg, "geometry_msgs/PoseStamped", {"pose": {}})
    assert msg["header"] == {"seq": 0, "stamp": NOW_DICT, "frame_id": ""}
    assert "header" not in missing and not any(m.startswith("header") for m in missing)


def test_header_without_stamp_gets_now(reg: TypeRegistry) -> None:
    msg, missing = convert(reg, "geometry_msgs/PoseStamped", {"header": {"frame_id": "map"}})
    assert msg["header"] == {"seq": 0, "stamp": NOW_DICT, "frame_id": "map"}
    assert missing == ["pose"]


def test_given_stamp_is_kept(reg: TypeRegistry) -> None:
    header = {"seq": 4, "stamp": {"secs": 1, "nsecs": 2}, "frame_id": "map"}
    msg, missing = convert(reg, "geometry_msgs/PoseStamped", {"header": header, "pose": {}})
    assert msg["header"] == header
    assert missing == ["pose.position", "pose.orientation"]


def test_header_frame_id_omission_is_reported(reg: TypeRegistry) -> None:
    _, missing = convert(reg, "geometry_msgs/PoseStamped", {"header": {}, "pose": {}})
    assert "header.frame_id" in missing
    assert "header.stamp" not in missing and "header.seq" not in missing


def test_nested_headers_are_filled_too(reg: TypeRegistry) -> None:
    goal = {"goal_id": {"id": "g1"}, "goal": {"target_pose": {"header": {"frame_id": "map"}}}}
    msg, missing = convert(reg, "move_base_msgs/MoveBaseActionGoal", goal)
    assert msg["header"]["stamp"] == NOW_DICT
    assert msg["goal"]["target_pose"]["header"] == {"seq": 0, "stamp": NOW_DICT, "frame_id": "map"}
    assert msg["goal_id"]["stamp"] == {"secs": 0, "nsecs": 0}
    assert "goal_id.stamp" not in missing  # a default-filled stamp is normal
    assert "goal.target_pose.pose" in missing


def test_goal_id_without_stamp_is_not_missing(reg: TypeRegistry) -> None:
    """roslibjs 1.4.1's Goal.cancel() publishes {id} alone: stamp 0 cancels just that goal."""
    msg, missing = convert(reg, "actionlib_msgs/GoalID", {"id": "g1"})
    assert msg == {"stamp": {"secs": 0, "nsecs": 0}, "id": "g1"}
    assert missing == []


def test_now_is_read_once_per_call(reg: TypeRegistry) -> None:
    calls = []

    def now() -> tuple[int, int]:
        calls.append(1)
        return NOW

    value = {"goal": {"target_pose": {}}}
    from_json(reg.msg("move_base_msgs/MoveBaseActionGoal"), value, reg, now=now)
    assert len(calls) == 1
    from_json(reg.msg("geometry_msgs/Twist"), {}, reg, now=now)
    assert len(calls) == 1


# --- errors --------------------------------------------------------------------------------


def test_unknown_field(reg: TypeRegistry) -> None:
    assert error(reg, "geometry_msgs/Twist", {"linear": {}, "foo": 1}) == (
        "unknown field 'foo' for type geometry_msgs/Twist"
    )
    assert error(reg, "geometry_msgs/PoseStamped", {"pose": {"position": {"w": 1}}}) == (
        "unknown field 'pose.position.w' for type geometry_msgs/Point"
    )
    assert error(reg, "std_msgs/Time", {"data": {"secs": 1, "ms": 2}}) == (
        "unknown field 'data.ms' for type time"
    )


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        (
            "geometry_msgs/PoseStamped",
            {"pose": {"position": {"x": "1"}}},
            "field 'pose.position.x' must be a number, got string",
        ),
        ("std_msgs/Float64", {"data": True}, "field 'data' must be a number, got boolean"),
        ("std_msgs/Int32", {"data": True}, "field 'data' must be an integer, got boolean"),
        ("std_msgs/Int32", {"data": 1.5}, "field 'data' must be an integer, got number"),
        ("std_msgs/Int32", {"data": None}, "field 'data' must be an integer, got null"),
        ("std_msgs/Bool", {"data": 1}, "field 'data' must be a boolean, got integer"),
        ("std_msgs/String", {"data": 5}, "field 'data' must be a string, got integer"),
        (
            "geometry_msgs/Twist",
            {"linear": [1, 2, 3]},
            "field 'linear' must be an object (geometry_msgs/Vector3), got array",
        ),
        ("geometry_msgs/Twist", [1], "message must be an object (geometry_msgs/Twist), got array"),
        (
            "std_msgs/Float32MultiArray",
            {"data": 1.0},
            "field 'data' must be an array, got number",
        ),
        (
            "sensor_msgs/LaserScan",
            {"ranges": [1.0, "x"]},
            "field 'ranges[1]' must be a number, got string",
        ),
        (
            "sensor_msgs/JointState",
            {"name": ["a", 3]},
            "field 'name[1]' must be a string, got integer",
        ),
        (
            "visualization_msgs/MarkerArray",
            {"markers": [{}, {"pose": {"position": {"x": []}}}]},
            "field 'markers[1].pose.position.x' must be a number, got array",
        ),
        (
            "std_msgs/UInt8MultiArray",
            {"data": {"a": 1}},
            "field 'data' must be a base64 string or an array of integers 0-255, got object",
        ),
    ],
)
def test_wrong_type(reg: TypeRegistry, name: str, value: object, message: str) -> None:
    assert error(reg, name, value) == message


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("std_msgs/Int8", {"data": 128}, "field 'data' value 128 is out of range for int8"),
        ("std_msgs/UInt8", {"data": -1}, "field 'data' value -1 is out of range for uint8"),
        ("std_msgs/Byte", {"data": 200}, "field 'data' value 200 is out of range for byte"),
        (
            "std_msgs/UInt32",
            {"data": 2**32},
            "field 'data' value 4294967296 is out of range for uint32",
        ),
        ("std_msgs/Int64", {"data": 2**63}, "is out of range for int64"),
        (
            "nav_msgs/OccupancyGrid",
            {"data": [0, 1, -129]},
            "field 'data[2]' value -129 is out of range for int8",
        ),
        (
            "std_msgs/UInt8MultiArray",
            {"data": [1, 256]},
            "field 'data[1]' value 256 is out of range for uint8",
        ),
        (
            "std_msgs/UInt8MultiArray",
            {"data": [1, "a"]},
            "field 'data[1]' must be an integer, got string",
        ),
    ],
)
def test_out_of_range(reg: TypeRegistry, name: str, value: object, message: str) -> None:
    assert message in error(reg, name, value)


@pytest.mark.parametrize("text", ["not base64!", "abc", "YW=J"])
def test_bad_base64(reg: TypeRegistry, text: str) -> None:
    assert error(reg, "sensor_msgs/Image", {"data": text}).startswith(
        "field 'data' is not valid base64"
    )


def test_wrong_fixed_length(reg: TypeRegistry) -> None:
    assert error(reg, "geometry_msgs/PoseWithCovariance", {"covariance": [0.0] * 35}) == (
        "field 'covariance' must have exactly 36 elements, got 35"
    )
    assert error(reg, "unique_identifier_msgs/UUID", {"uuid": "AAEC"}) == (
        "field 'uuid' must have exactly 16 elements, got 3"
    )
    assert error(reg, "unique_identifier_msgs/UUID", {"uuid": [1, 2]}) == (
        "field 'uuid' must have exactly 16 elements, got 2"
    )


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        (
            "std_msgs/Header",
            {"stamp": "yesterday"},
            "field 'stamp' must be a time ({secs, nsecs}, seconds or \"now\"), got string",
        ),
        (
            "std_msgs/Duration",
            {"data": "now"},
            "field 'data' must be a duration ({secs, nsecs} or seconds), got string",
        ),
        ("std_msgs/Time", {"data": {"secs": "1"}}, "field 'data.secs' must be an integer"),
        ("std_msgs/Time", {"data": {"nsecs": 0.5}}, "field 'data.nsecs' must be an integer"),
        ("std_msgs/Time", {"data": -1}, "field 'data' seconds -1 out of range for time"),
        ("std_msgs/Time", {"data": 2**31}, "field 'data' seconds 2147483648 out of range"),
        ("std_msgs/Time", {"data": math.inf}, "field 'data' must be a finite number"),
        ("std_msgs/Time", {"data": None}, "field 'data' must be a time"),
    ],
)
def test_bad_time(reg: TypeRegistry, name: str, value: object, message: str) -> None:
    assert message in error(reg, name, value)


# --- defaults ------------------------------------------------------------------------------


def test_default_laser_scan(reg: TypeRegistry) -> None:
    msg = default_message(reg.msg("sensor_msgs/LaserScan"), reg)
    assert msg == {
        "header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0}, "frame_id": ""},
        "angle_min": 0.0,
        "angle_max": 0.0,
        "angle_increment": 0.0,
        "time_increment": 0.0,
        "scan_time": 0.0,
        "range_min": 0.0,
        "range_max": 0.0,
        "ranges": [],
        "intensities": [],
    }


def test_default_byte_arrays_and_fixed_message_arrays(reg: TypeRegistry) -> None:
    assert default_message(reg.msg("sensor_msgs/Image"), reg)["data"] == b""
    assert default_message(reg.msg("unique_identifier_msgs/UUID"), reg) == {"uuid": bytes(16)}
    info = default_message(reg.msg("sensor_msgs/CameraInfo"), reg)
    assert info["D"] == [] and info["K"] == [0.0] * 9
    status = default_message(reg.msg("actionlib_msgs/GoalStatus"), reg)
    assert status == {
        "goal_id": {"stamp": {"secs": 0, "nsecs": 0}, "id": ""},
        "status": 0,
        "text": "",
    }


def test_defaults_are_independent_objects(reg: TypeRegistry) -> None:
    mtype = reg.msg("geometry_msgs/PoseStamped")
    first, second = default_message(mtype, reg), default_message(mtype, reg)
    first["header"]["stamp"]["secs"] = 9
    first["pose"]["position"]["x"] = 1.0
    assert second == default_message(mtype, reg)
    assert second["header"]["stamp"]["secs"] == 0


def test_empty_service_request(reg: TypeRegistry) -> None:
    msg, missing = from_json(reg.srv("std_srvs/Empty").request, {}, reg)
    assert msg == {} and missing == []
    msg, missing = from_json(reg.srv("std_srvs/SetBool").request, {"data": True}, reg)
    assert msg == {"data": True} and missing == []


def test_big_integer_arrays_become_compact_numpy_arrays():
    import numpy as np

    from hitrobot_server.types import jsoncodec
    from hitrobot_server.types.convert import BIG_ARRAY, from_json
    from hitrobot_server.types.registry import TypeRegistry

    reg = TypeRegistry.default()
    grid = reg.msg("nav_msgs/OccupancyGrid")
    data = [(-1, 0, 100)[i % 3] for i in range(BIG_ARRAY + 5)]
    value, _ = from_json(grid, {"data": data}, reg)
    assert isinstance(value["data"], np.ndarray) and value["data"].dtype == np.int8
    assert jsoncodec.loads(jsoncodec.dumps(value))["data"] == data  # same JSON as a list
    with pytest.raises(ConversionError, match=rf"data\[{BIG_ARRAY + 4}\].*out of range"):
        from_json(grid, {"data": data[:-1] + [128]}, reg)
    small, _ = from_json(grid, {"data": data[:10]}, reg)
    assert small["data"] == data[:10]


# --- the seed's spellings (types/aliases.py) -------------------------------------------------


def test_seed_field_names_are_read_as_the_sdks(reg: TypeRegistry) -> None:
    q = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    msg, _ = convert(reg, "slamware_ros_sdk/RotateRequest", {"orientation": q})
    assert msg["rotation"] == q and "orientation" not in msg
    line = {"id": 1, "start": {"x": 0.0, "y": 0.0}, "end": {"x": 1.0, "y": 0.0}}
    for name in ("AddLinesRequest", "MoveLinesRequest"):
        msg, _ = convert(reg, f"slamware_ros_sdk/{name}", {"line": [line]})
        assert msg["lines"] == [line]
    both = error(reg, "slamware_ros_sdk/RotateRequest", {"orientation": q, "rotation": q})
    assert "'orientation'" in both and "'rotation'" in both
    # other types keep their strict field names (rotate_to has only `orientation`)
    assert "unknown field 'rotation'" in error(reg, "slamware_ros_sdk/RotateToRequest",
                                               {"orientation": q, "rotation": q})


def test_seed_int8_stcm_bytes_and_type_name(reg: TypeRegistry) -> None:
    req = reg.srv("slamware_ros_sdk/SyncSetStcm").request
    msg, _ = from_json(req, {"raw_stcm": [-1, -128, 0, 127, 200]}, reg, now=lambda: NOW)
    assert msg["raw_stcm"] == bytes([255, 128, 0, 127, 200])
    with pytest.raises(ConversionError, match="-129"):
        from_json(req, {"raw_stcm": [-129]}, reg, now=lambda: NOW)
    assert "-1 is out of range" in error(reg, "std_msgs/UInt8MultiArray",
                                         {"data": [-1]})
    seed = reg.msg("slamware_ros_sdk/BasicSensorValuedataArray")
    assert seed is reg.msg("slamware_ros_sdk/BasicSensorValueDataArray")


# --- numpy arrays (big ops arrive compacted from the worker process) ---------------------------

_NUMPY_CASES = [
    ("nav_msgs/OccupancyGrid", "data", np.array([-1, 0, 100] * 2000, dtype=np.int8)),
    ("nav_msgs/OccupancyGrid", "data", np.array([1, 2, 3], dtype=np.int16)),
    ("nav_msgs/OccupancyGrid", "data", np.array([1.0, 2.0] * 3000)),  # integral floats
    ("nav_msgs/OccupancyGrid", "data", np.array([1, 300] * 3000, dtype=np.int16)),
    ("nav_msgs/OccupancyGrid", "data", np.array([1.0, 2.5] * 3000)),
    ("sensor_msgs/Image", "data", np.array([0, 255] * 3000, dtype=np.uint8)),
    ("sensor_msgs/Image", "data", np.array([0, 256] * 3000, dtype=np.int16)),
    ("sensor_msgs/LaserScan", "ranges", np.linspace(0.0, 30.0, 5000)),
    ("sensor_msgs/LaserScan", "ranges", np.arange(100, dtype=np.int32)),
    ("geometry_msgs/PoseWithCovariance", "covariance", np.zeros(35)),
    ("geometry_msgs/PoseWithCovariance", "covariance", np.ones(36)),
    ("sensor_msgs/LaserScan", "header", np.arange(3)),
    ("diagnostic_msgs/DiagnosticStatus", "values", np.arange(2000)),
    ("sensor_msgs/JointState", "name", np.arange(5)),
]


@pytest.mark.parametrize("name,field,array", _NUMPY_CASES)
def test_numpy_array_converts_or_fails_exactly_as_the_list(reg, name, field, array):
    as_list = array.tolist()
    try:
        expected, _ = convert(reg, name, {field: as_list})
    except ConversionError as exc:
        assert error(reg, name, {field: array}) == str(exc)
        return
    got, _ = convert(reg, name, {field: array})
    value, want = got[field], expected[field]
    if isinstance(want, np.ndarray):
        assert value.dtype == want.dtype and np.array_equal(value, want)
    elif isinstance(value, np.ndarray):  # a long array stays numpy: the same values
        assert value.tolist() == want and len(value) >= 4096
    else:
        assert value == want and type(value) is type(want)


# --- verbatim: may the client's own text of the message be sent on? ---------------------------

_VERBATIM = {"header": {"seq": 3, "stamp": {"secs": 1, "nsecs": 2}, "frame_id": "l"},
             "angle_min": -1.0, "angle_max": 1.0, "angle_increment": 0.5, "time_increment": 0.0,
             "scan_time": 0.1, "range_min": 0.1, "range_max": 30.0, "ranges": [1.5, 2.5],
             "intensities": []}


def _verbatim(reg, value) -> bool:
    from hitrobot_server.types.convert import from_json_verbatim
    msg, _, same = from_json_verbatim(reg.msg("sensor_msgs/LaserScan"), value, reg,
                                      now=lambda: NOW)
    if same:
        assert msg == value
    return same


def test_a_canonical_message_is_verbatim(reg):
    assert _verbatim(reg, _VERBATIM)
    reordered = dict(reversed(list(_VERBATIM.items())))
    assert _verbatim(reg, reordered)  # key order is not meaning in JSON


@pytest.mark.parametrize("change", [
    {"angle_min": -1},  # an int where a float goes: the output says -1.0
    {"ranges": [1, 2.5]},
    {"ranges": [None]},  # null means NaN
    {"range_min": None},
    {"header": {"stamp": {"secs": 1, "nsecs": 2}, "frame_id": "l"}},  # seq filled
    {"header": {"seq": 3, "frame_id": "l"}},  # stamp filled
    {"header": {"seq": 3.0, "stamp": {"secs": 1, "nsecs": 2}, "frame_id": "l"}},
    {"header": {"seq": 3, "stamp": {"sec": 1, "nanosec": 2}, "frame_id": "l"}},
    {"header": {"seq": 3, "stamp": {"secs": 1, "nsecs": 2_000_000_000}, "frame_id": "l"}},
    {"header": {"seq": 3, "stamp": 1.5, "frame_id": "l"}},
    {"header": {"seq": 3, "stamp": "now", "frame_id": "l"}},
])
def test_any_fill_retype_or_rename_is_not_verbatim(reg, change):
    assert not _verbatim(reg, {**_VERBATIM, **change})
    missing = dict(_VERBATIM)
    del missing["scan_time"]
    assert not _verbatim(reg, missing)


def test_byte_arrays_are_never_verbatim(reg):
    from hitrobot_server.types.convert import from_json_verbatim
    for data in ([1, 2], "AQI="):
        _, _, same = from_json_verbatim(reg.msg("std_msgs/UInt8MultiArray"),
                                        {"layout": {"dim": [], "data_offset": 0}, "data": data},
                                        reg)
        assert not same


def test_an_omitted_optional_value_is_not_reported_missing(reg: TypeRegistry) -> None:
    """The console's Relocalize sends ``options: {}``: its Optional* fields mean "not given"."""
    mtype = reg.msg("slamware_ros_sdk/RecoverLocalizationRequest")
    msg, missing = from_json(mtype, {"area": {"x": 0, "y": 0, "w": 0, "h": 0}, "options": {}},
                             reg)
    assert missing == []
    assert msg["options"]["max_time_ms"] == {"is_valid": False, "value": 0}
    assert msg["options"]["mvmt_type"]["is_valid"] is False
    # a plain field left out is still reported, and so is a wrapper's own part
    _, missing = from_json(mtype, {"options": {"max_time_ms": {"value": 5}}}, reg)
    assert missing == ["area", "options.max_time_ms.is_valid"]

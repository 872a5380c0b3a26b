"""rosapi TypeDef lists: order, array lengths, examples, constants, services."""

from __future__ import annotations

import pytest

from hitrobot_server.types.registry import TypeRegistry, UnknownType
from hitrobot_server.types.typedef import srv_request_typedefs, srv_response_typedefs, typedefs

TIME_TYPEDEF = {
    "type": "time",
    "fieldnames": ["secs", "nsecs"],
    "fieldtypes": ["int32", "int32"],
    "fieldarraylen": [-1, -1],
    "examples": ["0", "0"],
    "constnames": [],
    "constvalues": [],
}


@pytest.fixture(scope="module")
def reg() -> TypeRegistry:
    return TypeRegistry.default()


def test_pose_stamped(reg: TypeRegistry) -> None:
    defs = typedefs(reg, "geometry_msgs/PoseStamped")
    assert [d["type"] for d in defs] == [
        "geometry_msgs/PoseStamped",
        "std_msgs/Header",
        "time",
        "geometry_msgs/Pose",
        "geometry_msgs/Point",
        "geometry_msgs/Quaternion",
    ]
    assert defs[0] == {
        "type": "geometry_msgs/PoseStamped",
        "fieldnames": ["header", "pose"],
        "fieldtypes": ["std_msgs/Header", "geometry_msgs/Pose"],
        "fieldarraylen": [-1, -1],
        "examples": ["{}", "{}"],
        "constnames": [],
        "constvalues": [],
    }
    assert defs[1]["fieldtypes"] == ["uint32", "time", "string"]
    assert defs[1]["examples"] == ["0", "{}", ""]
    assert defs[2] == TIME_TYPEDEF
    assert defs[4]["examples"] == ["0.0", "0.0", "0.0"]
    assert typedefs(reg, "geometry_msgs/msg/PoseStamped") == defs


def test_arrays_and_duplicates(reg: TypeRegistry) -> None:
    defs = typedefs(reg, "nav_msgs/Path")
    assert defs[0]["fieldarraylen"] == [-1, 0]
    assert defs[0]["examples"] == ["{}", "[]"]
    types = [d["type"] for d in defs]
    assert types.count("std_msgs/Header") == 1 and types.count("time") == 1
    cov = typedefs(reg, "geometry_msgs/PoseWithCovariance")[0]
    assert cov["fieldtypes"] == ["geometry_msgs/Pose", "float64"]
    assert cov["fieldarraylen"] == [-1, 36]
    assert cov["examples"] == ["{}", "[]"]


def test_examples_per_base_type(reg: TypeRegistry) -> None:
    info = typedefs(reg, "sensor_msgs/NavSatStatus")[0]
    assert info["examples"] == ["0", "0"]
    status = typedefs(reg, "actionlib_msgs/GoalStatus")[0]
    assert status["examples"] == ["{}", "0", ""]
    assert typedefs(reg, "std_msgs/Bool")[0]["examples"] == ["False"]
    assert typedefs(reg, "std_msgs/Duration")[1]["type"] == "duration"


def test_constants_are_sorted_by_name_with_string_values(reg: TypeRegistry) -> None:
    status = typedefs(reg, "actionlib_msgs/GoalStatus")[0]
    assert status["constnames"] == sorted(status["constnames"])
    pairs = dict(zip(status["constnames"], status["constvalues"], strict=True))
    assert pairs["SUCCEEDED"] == "3" and pairs["LOST"] == "9"
    assert len(pairs) == 10


def test_service_typedefs(reg: TypeRegistry) -> None:
    request = srv_request_typedefs(reg, "nav_msgs/GetPlan")
    assert request[0] == {
        "type": "nav_msgs/GetPlanRequest",
        "fieldnames": ["start", "goal", "tolerance"],
        "fieldtypes": ["geometry_msgs/PoseStamped", "geometry_msgs/PoseStamped", "float32"],
        "fieldarraylen": [-1, -1, -1],
        "examples": ["{}", "{}", "0.0"],
        "constnames": [],
        "constvalues": [],
    }
    assert [d["type"] for d in request[1:3]] == ["geometry_msgs/PoseStamped", "std_msgs/Header"]
    response = srv_response_typedefs(reg, "std_srvs/srv/Trigger")
    assert response == [
        {
            "type": "std_srvs/TriggerResponse",
            "fieldnames": ["success", "message"],
            "fieldtypes": ["bool", "string"],
            "fieldarraylen": [-1, -1],
            "examples": ["False", ""],
            "constnames": [],
            "constvalues": [],
        }
    ]
    assert srv_request_typedefs(reg, "std_srvs/Empty")[0]["fieldnames"] == []


def test_unknown_types_raise(reg: TypeRegistry) -> None:
    with pytest.raises(UnknownType):
        typedefs(reg, "nope/Nope")
    with pytest.raises(UnknownType):
        srv_request_typedefs(reg, "std_msgs/String")

"""Type registry: name spellings, schema loading, srv/action registration, definition text."""

from __future__ import annotations

from pathlib import Path

import pytest

from hitrobot_server.types.registry import (
    Field,
    TypeRegistry,
    UnknownType,
    schema_dirs,
)

REPO_SCHEMAS = Path(__file__).resolve().parents[2] / "schemas"


@pytest.fixture(scope="module")
def reg() -> TypeRegistry:
    return TypeRegistry.default()


def test_default_is_a_singleton_using_repo_schemas() -> None:
    assert TypeRegistry.default() is TypeRegistry.default()
    assert schema_dirs() == [REPO_SCHEMAS]


@pytest.mark.parametrize(
    "spelling", ["geometry_msgs/Twist", "geometry_msgs/msg/Twist", "/geometry_msgs/Twist"]
)
def test_msg_spellings_resolve_to_the_same_cached_object(reg: TypeRegistry, spelling: str) -> None:
    mtype = reg.msg(spelling)
    assert mtype is reg.msg("geometry_msgs/msg/Twist")
    assert mtype.name == "geometry_msgs/msg/Twist"
    assert [f.name for f in mtype.fields] == ["linear", "angular"]
    assert mtype.fields[0] == Field("linear", "geometry_msgs/msg/Vector3", True, None)


@pytest.mark.parametrize("name", ["foo/Bar", "geometry_msgs/Nope", "Twist", "a/b/c/d", ""])
def test_unknown_msg(reg: TypeRegistry, name: str) -> None:
    with pytest.raises(UnknownType, match=f"unknown message type '{name}'"):
        reg.msg(name)
    assert not reg.has_msg(name)


def test_unknown_srv_and_action_messages(reg: TypeRegistry) -> None:
    with pytest.raises(UnknownType, match="unknown service type 'foo/Bar'"):
        reg.srv("foo/Bar")
    with pytest.raises(UnknownType, match="unknown action type 'foo/Bar'"):
        reg.action("foo/Bar")
    assert isinstance(UnknownType("x"), LookupError)


def test_field_shapes(reg: TypeRegistry) -> None:
    scan = {f.name: f for f in reg.msg("sensor_msgs/LaserScan").fields}
    assert scan["header"] == Field("header", "std_msgs/msg/Header", True, None)
    assert scan["ranges"] == Field("ranges", "float32", False, 0)
    cov = reg.msg("geometry_msgs/PoseWithCovariance").fields[1]
    assert cov == Field("covariance", "float64", False, 36)
    header = {f.name: f for f in reg.msg("std_msgs/Header").fields}
    assert header["stamp"] == Field("stamp", "time", False, None)
    assert reg.msg("std_msgs/Duration").fields[0].type == "duration"
    assert reg.msg("unique_identifier_msgs/UUID").fields[0] == Field("uuid", "uint8", False, 16)


def test_has_header(reg: TypeRegistry) -> None:
    assert reg.msg("sensor_msgs/LaserScan").has_header
    assert reg.msg("geometry_msgs/PoseStamped").has_header
    assert not reg.msg("geometry_msgs/Pose").has_header
    assert not reg.msg("std_msgs/Header").has_header


def test_constants(reg: TypeRegistry) -> None:
    consts = reg.msg("action_msgs/GoalStatus").constants
    assert consts[0] == ("STATUS_UNKNOWN", "int8", 0)
    assert consts[-1] == ("STATUS_ABORTED", "int8", 6)
    assert ("SUCCEEDED", "uint8", 3) in reg.msg("actionlib_msgs/GoalStatus").constants


def test_services(reg: TypeRegistry) -> None:
    srv = reg.srv("std_srvs/SetBool")
    assert srv is reg.srv("std_srvs/srv/SetBool")
    assert srv.name == "std_srvs/srv/SetBool"
    assert srv.request.name == "std_srvs/srv/SetBool_Request"
    assert [f.name for f in srv.request.fields] == ["data"]
    assert [f.name for f in srv.response.fields] == ["success", "message"]
    empty = reg.srv("std_srvs/Empty")
    assert empty.request.fields == () and empty.response.fields == ()
    plan = reg.srv("nav_msgs/GetPlan")
    assert [(f.name, f.type) for f in plan.request.fields] == [
        ("start", "geometry_msgs/msg/PoseStamped"),
        ("goal", "geometry_msgs/msg/PoseStamped"),
        ("tolerance", "float32"),
    ]
    assert plan.response.fields[0] == Field("plan", "nav_msgs/msg/Path", True, None)
    assert reg.srv("nav_msgs/GetMap").response.fields[0].type == "nav_msgs/msg/OccupancyGrid"
    assert reg.has_srv("rosapi/GetTime") and not reg.has_srv("geometry_msgs/Twist")


def test_rosapi_and_rosauth_field_names(reg: TypeRegistry) -> None:
    def names(part) -> list[str]:
        return [f.name for f in part.fields]

    assert names(reg.msg("rosapi/TypeDef")) == [
        "type",
        "fieldnames",
        "fieldtypes",
        "fieldarraylen",
        "examples",
        "constnames",
        "constvalues",
    ]
    assert names(reg.srv("rosapi/TopicsAndRawTypes").response) == [
        "topics",
        "types",
        "typedefs_full_text",
    ]
    assert names(reg.srv("rosapi/GetParam").request) == ["name", "default"]
    assert names(reg.srv("rosapi/SearchParam").response) == ["global_name"]
    assert names(reg.srv("rosapi/NodeDetails").response) == [
        "subscribing",
        "publishing",
        "services",
    ]
    assert names(reg.srv("rosapi/GetActionServers").response) == ["action_servers"]
    details = reg.srv("rosapi/MessageDetails").response.fields[0]
    assert details == Field("typedefs", "rosapi/msg/TypeDef", True, 0)
    assert reg.srv("rosapi/GetTime").response.fields[0] == Field("time", "time", False, None)
    auth = reg.srv("rosauth/Authentication")
    assert [(f.name, f.type) for f in auth.request.fields] == [
        ("mac", "string"),
        ("client", "string"),
        ("dest", "string"),
        ("rand", "string"),
        ("t", "time"),
        ("level", "string"),
        ("end", "time"),
    ]
    assert names(auth.response) == ["authenticated"]


@pytest.mark.parametrize(
    "spelling",
    [
        "move_base_msgs/MoveBase",
        "move_base_msgs/action/MoveBase",
        "move_base_msgs/MoveBaseAction",
        "/move_base_msgs/MoveBase",
    ],
)
def test_action_spellings(reg: TypeRegistry, spelling: str) -> None:
    action = reg.action(spelling)
    assert action is reg.action("move_base_msgs/action/MoveBase")
    assert action.goal.name == "move_base_msgs/action/MoveBase_Goal"
    assert action.goal.fields == (
        Field("target_pose", "geometry_msgs/msg/PoseStamped", True, None),
    )
    assert action.result.fields == ()
    assert action.feedback.fields == (
        Field("base_position", "geometry_msgs/msg/PoseStamped", True, None),
    )


def test_actionlib_wrappers_have_genaction_layout(reg: TypeRegistry) -> None:
    def layout(name: str) -> list[tuple[str, str]]:
        return [(f.name, f.type) for f in reg.msg(name).fields]

    assert layout("move_base_msgs/MoveBaseGoal") == [
        ("target_pose", "geometry_msgs/msg/PoseStamped")
    ]
    assert layout("move_base_msgs/MoveBaseActionGoal") == [
        ("header", "std_msgs/msg/Header"),
        ("goal_id", "actionlib_msgs/msg/GoalID"),
        ("goal", "move_base_msgs/msg/MoveBaseGoal"),
    ]
    assert layout("move_base_msgs/MoveBaseActionResult") == [
        ("header", "std_msgs/msg/Header"),
        ("status", "actionlib_msgs/msg/GoalStatus"),
        ("result", "move_base_msgs/msg/MoveBaseResult"),
    ]
    assert layout("move_base_msgs/MoveBaseActionFeedback") == [
        ("header", "std_msgs/msg/Header"),
        ("status", "actionlib_msgs/msg/GoalStatus"),
        ("feedback", "move_base_msgs/msg/MoveBaseFeedback"),
    ]
    assert layout("move_base_msgs/MoveBaseAction") == [
        ("action_goal", "move_base_msgs/msg/MoveBaseActionGoal"),
        ("action_result", "move_base_msgs/msg/MoveBaseActionResult"),
        ("action_feedback", "move_base_msgs/msg/MoveBaseActionFeedback"),
    ]
    assert reg.msg("move_base_msgs/MoveBaseActionGoal").has_header


def test_nav2_actions(reg: TypeRegistry) -> None:
    nav = reg.action("nav2_msgs/NavigateToPose")
    assert [f.name for f in nav.goal.fields] == ["pose", "behavior_tree"]
    assert nav.result.fields == (Field("result", "std_msgs/msg/Empty", True, None),)
    assert [(f.name, f.type) for f in nav.feedback.fields] == [
        ("current_pose", "geometry_msgs/msg/PoseStamped"),
        ("navigation_time", "duration"),
        ("estimated_time_remaining", "duration"),
        ("number_of_recoveries", "int16"),
        ("distance_remaining", "float32"),
    ]
    plan = reg.action("nav2_msgs/ComputePathToPose")
    assert [f.name for f in plan.goal.fields] == ["goal", "start", "planner_id", "use_start"]
    assert [f.name for f in plan.result.fields] == ["path", "planning_time"]
    assert plan.feedback.fields == ()
    follow = reg.action("nav2_msgs/FollowPath")
    assert [f.name for f in follow.goal.fields] == ["path", "controller_id", "goal_checker_id"]
    assert [f.name for f in follow.feedback.fields] == ["distance_to_goal", "speed"]
    assert reg.has_msg("nav2_msgs/NavigateToPoseActionGoal")


def test_actionlib_actions_from_the_rosbags_store(reg: TypeRegistry) -> None:
    action = reg.action("nav_msgs/GetMap")
    assert action.result.fields == (Field("map", "nav_msgs/msg/OccupancyGrid", True, None),)
    assert reg.has_action("nav_msgs/GetMapAction")
    assert not reg.has_action("geometry_msgs/Twist")


def test_names_lists(reg: TypeRegistry) -> None:
    msgs = reg.msg_names()
    assert "tf2_msgs/msg/TFMessage" in msgs and "std_msgs/msg/String" in msgs
    assert not any(
        "/srv/" in n or "/action/" in n or n.startswith("builtin_interfaces") for n in msgs
    )
    assert "std_srvs/srv/Trigger" in reg.srv_names()
    assert {"move_base_msgs/action/MoveBase", "nav2_msgs/action/FollowPath"} <= set(
        reg.action_names()
    )
    assert not reg.has_msg("builtin_interfaces/Time")


@pytest.mark.parametrize(
    ("name", "short"),
    [
        ("geometry_msgs/msg/Twist", "geometry_msgs/Twist"),
        ("std_srvs/srv/SetBool", "std_srvs/SetBool"),
        ("std_srvs/srv/SetBool_Request", "std_srvs/SetBoolRequest"),
        ("std_srvs/srv/SetBool_Response", "std_srvs/SetBoolResponse"),
        ("nav2_msgs/action/FollowPath_Goal", "nav2_msgs/FollowPathGoal"),
        ("nav2_msgs/action/FollowPath", "nav2_msgs/FollowPath"),
        ("geometry_msgs/Twist", "geometry_msgs/Twist"),
    ],
)
def test_short(name: str, short: str) -> None:
    assert TypeRegistry.short(name) == short


def test_definition_text(reg: TypeRegistry) -> None:
    text = reg.definition_text("geometry_msgs/PoseStamped")
    blocks = text.split("=" * 80 + "\n")
    assert blocks[0] == "std_msgs/Header header\ngeometry_msgs/Pose pose\n"
    assert blocks[1] == "MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n"
    assert [b.split("\n", 1)[0] for b in blocks[1:]] == [
        "MSG: std_msgs/Header",
        "MSG: geometry_msgs/Pose",
        "MSG: geometry_msgs/Point",
        "MSG: geometry_msgs/Quaternion",
    ]
    assert reg.definition_text("geometry_msgs/msg/PoseStamped") is text
    goal = reg.definition_text("move_base_msgs/MoveBaseActionGoal")
    assert goal.startswith("std_msgs/Header header\nactionlib_msgs/GoalID goal_id\n")
    assert "MSG: move_base_msgs/MoveBaseGoal\ngeometry_msgs/PoseStamped target_pose\n" in goal
    status = reg.definition_text("action_msgs/GoalStatus")
    assert status.startswith("int8 STATUS_UNKNOWN=0\n")


def test_extra_dirs_are_loaded(tmp_path: Path) -> None:
    pkg = tmp_path / "demo_msgs"
    (pkg / "msg").mkdir(parents=True)
    (pkg / "srv").mkdir()
    (pkg / "action").mkdir()
    (pkg / "msg" / "Blob.msg").write_text("Header header\nPart[] parts\n")
    (pkg / "msg" / "Part.msg").write_text("uint8 KIND=3\nstring name\n")
    (pkg / "srv" / "Fetch.srv").write_text("string key\n---\nBlob blob\n")
    (pkg / "action" / "Spin.action").write_text("float64 turns\n---\n---\nfloat64 done\n")
    reg = TypeRegistry([tmp_path])
    assert reg.msg("demo_msgs/Blob").fields[1] == Field("parts", "demo_msgs/msg/Part", True, 0)
    assert reg.srv("demo_msgs/Fetch").response.fields[0].type == "demo_msgs/msg/Blob"
    assert reg.action("demo_msgs/SpinAction").goal.fields[0].name == "turns"
    assert reg.has_msg("demo_msgs/SpinActionFeedback")
    assert not TypeRegistry.default().has_msg("demo_msgs/Blob")


def test_bad_schema_files_fail_at_load(tmp_path: Path) -> None:
    (tmp_path / "bad_msgs" / "srv").mkdir(parents=True)
    (tmp_path / "bad_msgs" / "srv" / "Odd.srv").write_text("string a\n")
    with pytest.raises(ValueError, match="expected 1 '---' separator"):
        TypeRegistry([tmp_path])
    dangling = tmp_path / "dangling"
    (dangling / "more_msgs" / "msg").mkdir(parents=True)
    (dangling / "more_msgs" / "msg" / "Ref.msg").write_text("Missing thing\n")
    with pytest.raises(
        ValueError, match="field 'thing' refers to unknown type more_msgs/msg/Missing"
    ):
        TypeRegistry([dangling])


def test_every_schema_file_is_registered(reg: TypeRegistry) -> None:
    for path in REPO_SCHEMAS.glob("*/*/*"):
        pkg, kind = path.parts[-3], path.parts[-2]
        name = f"{pkg}/{path.stem}"
        assert {"msg": reg.has_msg, "srv": reg.has_srv, "action": reg.has_action}[kind](name), path


def test_an_action_part_is_found_by_the_short_name_rosapi_lists(reg):
    """rosapi lists ``pkg/action/X_FeedbackMessage`` as ``pkg/X_FeedbackMessage``; that name
    must find it again (and the hidden services' types), and a real pkg/msg type still wins."""
    feedback = reg.msg("nav2_msgs/FollowPath_FeedbackMessage")
    assert feedback.name == "nav2_msgs/action/FollowPath_FeedbackMessage"
    assert [f.name for f in feedback.fields] == ["goal_id", "feedback"]
    assert reg.short(feedback.name) == "nav2_msgs/FollowPath_FeedbackMessage"
    assert "goal_id" in reg.definition_text("nav2_msgs/FollowPath_FeedbackMessage")
    assert reg.srv("nav2_msgs/FollowPath_GetResult").name == "nav2_msgs/action/FollowPath_GetResult"
    assert reg.msg("example_interfaces/FibonacciFeedback").name.startswith(
        "example_interfaces/msg/")
    with pytest.raises(UnknownType):
        reg.msg("nav2_msgs/NoSuch_FeedbackMessage")

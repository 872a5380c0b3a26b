"""protocol/access.py called directly: the role table, the classification of names, the agent's
limits, the roles file and rosauth's levels (issue 47 items 2 and 3)."""

from __future__ import annotations

import asyncio
import json

import pytest

from hitrobot_server.protocol.access import (
    NOBODY,
    PERMISSIONS,
    ROLES,
    RULES,
    Limits,
    Role,
    allowed,
    goal_point,
    permission,
    roles_from,
    rosauth_role,
)

VIEWER, OPERATOR, ADMIN, AGENT, MONITOR = (ROLES[n] for n in
                                           ("viewer", "operator", "admin", "agent", "monitor"))

# (kind, name, permission): one row per thing a site cares about
CLASSIFIED = [
    ("subscribe", "/scan", "read"),
    ("subscribe", "/r1/cmd_vel", "read"),
    ("publish", "/cmd_vel", "drive"),
    ("publish", "/r1/cmd_vel", "drive"),
    ("publish", "/cmd_string", "shell"),
    ("publish", "/system_shell/cmd_string", "shell"),
    ("publish", "/move_base_simple/goal", "goals"),
    ("publish", "/move_base/goal", "goals"),
    ("publish", "/move_base/cancel", "cancel"),
    ("publish", "/navigation/navigate_to_poi", "goals"),
    ("publish", "/map_manager/add_poi", "pois"),
    ("publish", "/map_manager/delete_poi", "pois"),
    ("publish", "/map_manager/modify_poi", "pois"),
    ("publish", "/map_manager/modify_map", "walls"),
    ("publish", "/map_manager/load_map", "maps"),
    ("publish", "/map_manager/save_map", "maps"),
    ("publish", "/slamware_ros_sdk_server_node/add_line", "walls"),
    ("publish", "/slamware_ros_sdk_server_node/clear_map", "maps"),
    ("publish", "/slamware_ros_sdk_server_node/move_to", "moves"),
    ("publish", "/initialpose", "localize"),
    ("publish", "/tf", "localize"),
    ("publish", "/map", "maps"),
    ("publish", "/tf2_web_republisher/goal", "read"),
    ("publish", "/chatter", "publish"),
    ("call", "/rosapi/topics", "read"),
    ("call", "/rosapi/get_param", "read"),
    ("call", "/rosapi/set_param", "params"),
    ("call", "/rosapi/delete_param", "params"),
    ("call", "/map_manager/get_pois", "read"),
    ("call", "/record/list", "read"),
    ("call", "/record/start", "record"),
    ("call", "/record/replay", "record"),
    ("call", "/planning/start_patrol", "patrols"),
    ("call", "/planning/list_waypoints_files", "read"),
    ("call", "/fleet/dispatch", "dispatch"),
    ("call", "/fleet/cancel", "cancel"),
    ("call", "/fleet/zone_add", "walls"),
    ("call", "/fleet/history", "read"),
    ("call", "/load_laser_map", "maps"),
    ("call", "/slamware_ros_sdk_server_node/set_parameters", "params"),
    ("call", "/slamware_ros_sdk_server_node/get_parameters", "read"),
    ("call", "/sim/set_battery", "settings"),
    ("call", "/stand_up", "settings"),
    ("call", "/hitrobot/whoami", "whoami"),
    ("call", "/someone/else", "call"),
    ("goal", "/move_base", "goals"),
    ("goal", "/tf2_web_republisher", "read"),
    ("cancel", "/move_base", "cancel"),
    ("provide", "/my_service", "provide"),
    ("param_get", "/robot/x", "read"),
    ("param_set", "/robot/x", "params"),
    ("playback", "/playback", "record"),
    ("http", "/metrics", "metrics"),
    ("http", "/healthz", "metrics"),
    ("http", "/recordings/a.mcap", "download"),
    ("http", "/index.html", "console"),
]


@pytest.mark.parametrize(("kind", "name", "perm"), CLASSIFIED)
def test_each_name_needs_its_permission(kind, name, perm):
    assert permission(kind, name) == perm


def test_every_rule_names_a_known_permission_and_kind():
    from hitrobot_server.protocol.access import KINDS

    for kinds, _pattern, perm in RULES:
        assert perm in PERMISSIONS and kinds <= set(KINDS)
    with pytest.raises(ValueError):
        permission("teleport", "/x")


def test_the_roles_nest_as_the_issue_says():
    assert VIEWER.permissions < OPERATOR.permissions < ADMIN.permissions
    assert MONITOR.permissions == {"metrics"}
    assert {"drive", "goals", "pois", "walls", "patrols", "dispatch", "cancel",
            "record"} <= OPERATOR.permissions - VIEWER.permissions
    assert {"maps", "settings", "shell", "params", "tokens"} <= (
        ADMIN.permissions - OPERATOR.permissions)
    assert not {"shell", "maps", "pois", "params"} & AGENT.permissions
    assert AGENT.limits is not None and ADMIN.limits is None


@pytest.mark.parametrize("role", [*ROLES.values(), NOBODY], ids=lambda r: r.name)
@pytest.mark.parametrize(("kind", "name", "perm"), CLASSIFIED)
def test_a_refusal_names_the_role_and_the_permission(role, kind, name, perm):
    reason = allowed(role, kind, name)
    if perm in role.permissions or perm == "whoami":
        assert reason is None or role.limits is not None
    else:
        assert reason is not None and f"'{role.name}'" in reason and f"'{perm}'" in reason


def test_the_agent_drives_under_its_cap_and_is_refused_over_it():
    slow = {"linear": {"x": 0.2, "y": 0.0, "z": 0.0}, "angular": {"x": 0, "y": 0, "z": 0.3}}
    assert allowed(AGENT, "publish", "/cmd_vel", slow) is None
    fast = {"linear": {"x": 1.0}, "angular": {"z": 0.0}}
    reason = allowed(AGENT, "publish", "/cmd_vel", fast)
    assert reason is not None and "at most 0.3 m/s" in reason
    spin = {"linear": {"x": 0.0}, "angular": {"z": -2.0}}
    assert "rad/s" in (allowed(AGENT, "publish", "/cmd_vel", spin) or "")
    junk = {"linear": {"x": "fast"}}
    assert allowed(AGENT, "publish", "/cmd_vel", junk) is not None
    assert allowed(OPERATOR, "publish", "/cmd_vel", fast) is None  # no cap for an operator


def test_the_agent_sends_goals_to_pois_and_inside_its_zones_only():
    zoned = Role("agent", AGENT.permissions, Limits(zones=((0, 0, 5, 5),)))
    inside = {"header": {"frame_id": "map"}, "pose": {"position": {"x": 1, "y": 2, "z": 0},
                                                       "orientation": {"w": 1}}}
    outside = {"pose": {"position": {"x": 9, "y": 2}}}
    assert allowed(zoned, "publish", "/move_base_simple/goal", inside) is None
    assert "outside" in allowed(zoned, "publish", "/move_base_simple/goal", outside)
    move_base = {"goal": {"target_pose": inside}}
    assert allowed(zoned, "goal", "/move_base", move_base) is None
    assert allowed(zoned, "publish", "/move_base/goal", {"goal": {"target_pose": outside}})
    assert allowed(zoned, "publish", "/navigation/navigate_to_poi", {"name": "dock"}) is None
    assert "no pose" in allowed(zoned, "goal", "/follow_path", {"path": {}})
    assert "no pose" in allowed(zoned, "goal", "/move_base")  # no args: no pose
    assert "no pose" in allowed(zoned, "call", "/move_base/_action/send_goal")
    send_goal = {"goal_id": {}, "goal": {"target_pose": inside}}
    assert allowed(zoned, "call", "/move_base/_action/send_goal", send_goal) is None
    assert allowed(AGENT, "publish", "/move_base_simple/goal", inside) is not None  # no zones
    assert allowed(AGENT, "publish", "/map_manager/add_poi", {}) is not None
    assert allowed(AGENT, "publish", "/cmd_string", {"data": "shutdown"}) is not None


def test_goal_point_finds_nested_poses_and_refuses_junk():
    assert goal_point({"pose": {"pose": {"position": {"x": 1.5, "y": -2}}}}) == (1.5, -2.0)
    assert goal_point({"position": {"x": float("nan"), "y": 0}}) is None
    assert goal_point([1, 2]) is None
    deep: dict = {}
    cursor = deep
    for _ in range(50):
        cursor["goal"] = {}
        cursor = cursor["goal"]
    assert goal_point(deep) is None


def test_a_roles_file_adds_and_replaces_roles():
    table = roles_from(json.dumps({
        "kiosk": {"permissions": ["read", "console"]},
        "agent": {"permissions": ["read", "drive", "goals"], "max_speed": 0.5,
                  "zones": [[0, 0, 10, 10]]}}))
    assert table.get("kiosk").permissions == {"read", "console"}
    assert table.get("agent").limits == Limits(0.5, 0.5, ((0, 0, 10, 10),))
    assert table.get("admin") == ADMIN and table.get("ghost") is NOBODY


@pytest.mark.parametrize(("text", "words"), [
    ("{", "not JSON"),
    ("[]", "object of roles"),
    ('{"x": {}}', "'permissions' list"),
    ('{"x": {"permissions": ["fly"]}}', "unknown permission"),
    ('{"x": {"permissions": [], "zones": [[1, 2]]}}', "bad limits"),
])
def test_a_bad_roles_file_is_refused_with_the_reason(text, words):
    with pytest.raises(ValueError, match=words):
        roles_from(text)


def test_rosauth_levels_map_to_roles():
    assert rosauth_role("admin") == "admin"
    assert rosauth_role("user") == rosauth_role("") == "operator"


def test_every_service_and_topic_of_the_server_is_classified_by_a_rule_of_its_own(
        make_server_sync):
    """No name the server offers falls through to the catch-all rows (``call`` / ``publish``
    of another client's names): a new service must be classified when it is added."""
    names = make_server_sync
    fallback = {("call", "call"), ("publish", "publish")}
    loose = [(kind, name) for kind, name in names if (kind, permission(kind, name)) in fallback]
    assert not loose, loose


@pytest.fixture(scope="module")
def make_server_sync(tmp_path_factory):
    """The names a simulated robot's server offers: (call, service) and (publish, topic a
    server node subscribes)."""
    from hitrobot_server.bus.graph import whole_graph
    from hitrobot_server.bus.names import CLIENT_NODE_PREFIX
    from hitrobot_server.config import Settings
    from hitrobot_server.server import HitrobotServer

    async def names():
        server = HitrobotServer(Settings.of(
            port=0, tcp_port=-1, address="127.0.0.1", robot="sim",
            state_dir=str(tmp_path_factory.mktemp("state")),
            map_dir=str(tmp_path_factory.mktemp("maps"))))
        await server.start()
        try:
            graph = whole_graph(server.bus)
            found = [("call", s) for s in graph.services]
            found += [("publish", t) for t, subs in graph.subscribers.items()
                      if any(not n.startswith(CLIENT_NODE_PREFIX) for n in subs)]
            return found
        finally:
            await server.stop()

    return asyncio.run(names())

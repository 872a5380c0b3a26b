"""Several robots in one server: names, namespaces, TF frames, refused names."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from hitrobot_server.cli import build_parser
from hitrobot_server.config import load
from hitrobot_server.robot.options import RobotEntry
from tests.helpers import Watcher


def parse(*argv: str):
    return load(build_parser().parse_args(list(argv)))


def test_named_robots_are_parsed():
    s = parse("--robot", "a=sim", "--robot", "b=sim@6,8,3.14", "--robot", "c=http://10.0.0.2:1448")
    assert [(e.name, e.spec, e.start) for e in s.robot_entries()] == [
        ("a", "sim", None), ("b", "sim", (6.0, 8.0, 3.14)), ("c", "http://10.0.0.2:1448", None)]


def test_a_single_unnamed_robot_stays_as_it_was():
    s = parse("--robot", "none")
    assert s.robot.robot == "none" and s.robots == ()
    assert s.robot_entries() == [RobotEntry("", "none")]
    assert parse().robot_entries() == [RobotEntry("", "sim")]


@pytest.mark.parametrize(("argv", "error"), [
    (["--robot", "a=sim", "--robot", "a=sim"], "robot name 'a' is given twice"),
    (["--robot", "2fast=sim", "--robot", "b=sim"], "robot name '2fast' is invalid"),
    (["--robot", "a-b=sim"], "robot name 'a-b' is invalid"),
    (["--robot", "map=sim", "--robot", "b=sim"], "would shadow the global name '/map'"),
    (["--robot", "move_base=sim"], "would shadow the global name '/move_base'"),
    (["--robot", "fleet=sim"], "would shadow the global name '/fleet'"),
    (["--robot", "sim", "--robot", "b=sim"], "name every robot"),
    (["--robot", "sim", "--robot", "sim"], "several robots need names"),
    (["--robot", "a=bogus"], "expected sim"),
    (["--robot", "a=sim@1"], "start pose"),
    (["--robot", "sim@1,2"], "needs a named robot"),
    (["--robot", "=sim"], "name before '=' is empty"),
])
def test_bad_robot_names_are_refused(argv, error):
    with pytest.raises(ValueError, match=error.replace("(", r"\(").replace(")", r"\)")):
        parse(*argv)


def test_robots_from_the_toml_config(tmp_path):
    cfg = tmp_path / "site.toml"
    cfg.write_text('[robots]\nalpha = "sim"\nbeta = "sim@6,8"\n')
    s = parse("--config", str(cfg))
    assert [(e.name, e.start) for e in s.robot_entries()] == [
        ("alpha", None), ("beta", (6.0, 8.0, 0.0))]
    cfg.write_text('[server]\nrobot = ["alpha=sim", "alpha=none"]\n')
    with pytest.raises(ValueError, match="given twice"):
        parse("--config", str(cfg))


def test_the_command_line_refuses_a_bad_name_before_starting():
    out = subprocess.run(
        [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "0",
         "--robot", "a=sim", "--robot", "rosout=sim"],
        capture_output=True, text=True, timeout=60)
    assert out.returncode == 2
    assert "robot name 'rosout' would shadow the global name '/rosout'" in out.stderr
    assert "ws://" not in out.stdout  # nothing was served


async def test_a_refused_start_pose_stops_what_started(make_server, tmp_path):
    robots = (RobotEntry("a", "sim", (6.0, 8.0, 0.0)), RobotEntry("b", "sim", (6.1, 8.0, 0.0)))
    with pytest.raises(ValueError, match="on another robot"):
        await make_server(robots=robots, map_dir=str(tmp_path))
    # nothing half-started: a second server with the same names starts cleanly
    server = await make_server(robots=robots[:1], map_dir=str(tmp_path))
    assert [u.name for u in server.robots] == ["a"]


def pose_of(msg: dict) -> tuple[float, float]:
    return msg["position"]["x"], msg["position"]["y"]


async def test_two_robots_each_under_its_own_name(make_server, tmp_path):
    server = await make_server(
        robots=(RobotEntry("a", "sim", (5.0, 8.0, 0.0)), RobotEntry("b", "sim", (8.0, 8.0, 0.0))),
        map_dir=str(tmp_path), sim_speed=3.0)
    bus = server.bus
    for name in ("/robot_pose", "/move_base_simple/goal", "/cmd_vel", "/move_base/status"):
        assert bus.topic(name) is None  # no global robot names in a fleet
    for robot in ("a", "b"):
        for name in ("robot_pose", "cmd_vel", "move_base_simple/goal", "move_base/status",
                     "slamware_ros_sdk_server_node/odom", "diagnostics_agg", "robot_state"):
            assert bus.topic(f"/{robot}/{name}") is not None, f"/{robot}/{name}"
        assert bus.service(f"/{robot}/planning/start_patrol") is not None
        assert bus.action(f"/{robot}/compute_path_to_pose") is not None
        assert bus.params.get(f"/{robot}/robot_id") == robot
        assert bus.params.get(f"/{robot}/slamware_ros_sdk_server_node/robot_frame") == (
            f"{robot}/base_link")
    assert bus.service("/map_manager/get_pois") is not None  # the site's, shared
    assert "/a/move_base" in bus.nodes and "/move_base" not in bus.nodes

    w = await Watcher.open(server.port)
    try:
        for topic in ("/a/robot_pose", "/b/robot_pose", "/tf", "/a/diagnostics_agg"):
            await w.subscribe(topic)
        await w.until(lambda: w.latest("/a/robot_pose") and w.latest("/b/robot_pose"), 10,
                      "both robots' poses")
        start_b = pose_of(w.latest("/b/robot_pose"))

        def frames() -> set[tuple[str, str]]:
            return {(t["header"]["frame_id"], t["child_frame_id"])
                    for _, m in w.messages.get("/tf", []) for t in m["transforms"]}

        await w.until(lambda: {("a/odom", "a/base_link"), ("b/odom", "b/base_link"),
                               ("/map", "a/laser"), ("/map", "b/laser")} <= frames(), 10,
                      "both robots' TF frames")
        diag = await w.next("/a/diagnostics_agg")
        names = {s["name"] for s in diag["status"]}
        assert "/Robot/Connection" in names and "/Bridge" not in names

        goal = {"header": {"frame_id": "map"},
                "pose": {"position": {"x": 3.0, "y": 8.0, "z": 0.0},
                         "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}}
        await w.publish("/a/move_base_simple/goal", goal, "geometry_msgs/PoseStamped")

        def a_arrived() -> bool:
            x, y = pose_of(w.latest("/a/robot_pose"))
            return math.hypot(x - 3.0, y - 8.0) < 0.25

        await w.until(a_arrived, 30, "robot a at its goal")
        for _, msg in w.messages["/b/robot_pose"]:  # b never moved
            x, y = pose_of(msg)
            assert math.hypot(x - start_b[0], y - start_b[1]) < 0.05
    finally:
        await w.close()


async def test_every_global_name_of_a_single_robot_is_reserved(make_server, tmp_path):
    """A robot named like any first segment of the single robot's names would shadow it."""
    from hitrobot_server.nodes.assembly import reserved_names

    RESERVED = reserved_names()

    server = await make_server(robot="sim", map_dir=str(tmp_path))
    bus = server.bus
    names = [*bus.topics, *bus.services, *bus.actions, *bus.nodes, *server.robots[0].bus.params
             .get("/")]
    firsts = {n.strip("/").split("/")[0] for n in names}
    firsts.discard("map")  # /map/robot_0/Odometry etc. start with the reserved 'map' anyway
    assert firsts <= RESERVED, sorted(firsts - RESERVED)

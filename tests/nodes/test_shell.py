"""``/cmd_string`` commands and ``/ros_mode`` (seed §4.1, §4.2, §4.4.5) over real WebSockets."""

from __future__ import annotations

import asyncio
import hashlib
import math
import time

import pytest

from hitrobot_server import __version__
from hitrobot_server.bus.names import CLIENT_NODE_PREFIX
from hitrobot_server.nodes.base import Node
from tests.helpers import Watcher
from tests.nodes.robot_setup import RobotSetup

NS = "/slamware_ros_sdk_server_node"
SECRET = "0123456789abcdef"
MODES = ("/ros_mode", "/system_shell/system_mode")


def auth_op(level: str) -> dict:
    t = int(time.time())
    end = t + 60
    mac = hashlib.sha512(f"{SECRET}127.0.0.1127.0.0.1r4nd{t}{level}{end}".encode()).hexdigest()
    return {"op": "auth", "mac": mac, "client": "127.0.0.1", "dest": "127.0.0.1",
            "rand": "r4nd", "t": t, "level": level, "end": end}


async def command(w: Watcher, text: str, op_id: str | None = None,
                  topic: str = "/cmd_string") -> None:
    await w.publish(topic, {"data": text}, "std_msgs/String", op_id=op_id)


async def status_for(w: Watcher, op_id: str, timeout: float = 5) -> dict:
    return await w.until(lambda: next((s for s in w.statuses if s.get("id") == op_id), None),
                         timeout, f"a status for {op_id}")


def modes(w: Watcher, topic: str) -> list[str]:
    return [msg["data"] for _t, msg in w.messages.get(topic, [])]


ROBOT = RobotSetup(sim_speed=4.0, watch=dict.fromkeys(MODES, "std_msgs/String"),
                   ready=lambda w: all(modes(w, t) for t in MODES), ready_what="the latched mode",
                   ready_timeout=5, map_dir=True)


async def test_mode_switches_publish_busy_then_the_mode(robot):
    w = robot.w
    await w.subscribe(f"{NS}/robot_basic_state")
    assert modes(w, "/ros_mode") == ["navigation"]  # the prebuilt map: not mapping
    await command(w, "gmapping", "g")
    await w.until(lambda: all(modes(w, t)[-2:] == ["busy", "gmapping"] for t in MODES), 5,
                  "busy, then gmapping")
    await w.until(lambda: (w.latest(f"{NS}/robot_basic_state") or {})
                  .get("is_map_building_enabled") is True, 3, "map building on")
    await command(w, "navigation", "n", topic="/system_shell/cmd_string")  # the JS example
    await w.until(lambda: all(modes(w, t)[-2:] == ["busy", "navigation"] for t in MODES), 5,
                  "busy, then navigation")
    await w.until(lambda: w.latest(f"{NS}/robot_basic_state")["is_map_building_enabled"]
                  is False, 3, "map building off")
    assert not [s for s in w.statuses if s.get("id") in ("g", "n")]

    # the mode follows the robot when mapping is switched by other means
    await w.publish(f"{NS}/set_map_update", {"enabled": True, "kind": {"kind": 0}},
                    "slamware_ros_sdk/SetMapUpdateRequest")
    await w.until(lambda: modes(w, "/ros_mode")[-1] == "gmapping", 3, "mode following the robot")


async def test_version_null_and_unknown_commands(robot):
    w = robot.w
    await w.subscribe("/system_shell/version", "std_msgs/String")
    await command(w, "version")
    text = (await w.until(lambda: w.latest("/system_shell/version"), 5, "a version"))["data"]
    assert f"hitrobot-server {__version__}" in text and "hitrobot-sim" in text
    await command(w, "null", "null")
    await command(w, "selfdestruct", "unknown")
    status = await status_for(w, "unknown")
    assert status["level"] == "error" and "unknown command 'selfdestruct'" in status["msg"]
    assert not [s for s in w.statuses if s.get("id") == "null"]


async def test_cancel_stops_move_base_goals_and_the_robot(robot):
    server, w = robot.server, robot.w
    await w.subscribe("/move_base/result")
    await w.publish("/move_base/goal", {"goal_id": {"id": "far"}, "goal": {"target_pose": {
        "header": {"frame_id": "map"},
        "pose": {"position": {"x": 20.0, "y": 8.2, "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}},
        "move_base_msgs/MoveBaseActionGoal")
    actions = server.robot.simulator.actions
    await w.until(lambda: actions.current_action() is not None, 5, "motion")
    await command(w, "cancel", "c")
    result = await w.until(lambda: w.latest("/move_base/result"), 5, "a result")
    assert result["status"]["goal_id"]["id"] == "far" and result["status"]["status"] == 2
    await w.until(lambda: actions.current_action() is None, 3, "robot idle")


async def test_map_commands_go_to_the_map_manager(robot):
    server, w = robot.server, robot.w
    probe = Node(server.bus, "/map_manager_probe")
    got: list[tuple[str, str]] = []
    for topic in ("/map_manager/save_map", "/map_manager/load_map"):
        probe.subscribe(topic, "map_messages/SaveMap",
                        lambda msg, topic=topic: got.append((topic, msg.msg["filename"])))
    try:
        for text in ("save_map", "save_map_edit", "save_as_map", "save_as_map_edit"):
            await command(w, text)
        await w.until(lambda: len(got) == 4, 5, "four map requests")
        assert got == [("/map_manager/save_map", "localization"),
                       ("/map_manager/save_map", "navigation"),
                       ("/map_manager/load_map", "localization"),
                       ("/map_manager/load_map", "navigation")]
    finally:
        probe.close()


async def test_the_map_managers_answer_to_the_shell_reaches_the_client(robot):
    """The shell asks on the client's behalf (its origin goes along) and relays the answer."""
    probe = Node(robot.server.bus, "/map_manager_answerer")
    origins = []

    def answer(message):
        origins.append(message.origin)
        message.reply.ok("save_map: heard you")

    probe.subscribe("/map_manager/save_map", "map_messages/SaveMap", answer)
    w = await Watcher.open(robot.server.port)
    try:
        await w.client.send({"op": "set_level", "level": "info"})
        await command(w, "save_map", "relayed")
        status = await status_for(w, "relayed")
        assert (status["level"], status["msg"]) == (
            "info", "publish to '/cmd_string': save_map: heard you")
        assert len(origins) == 1 and origins[0] is not None
        assert origins[0].node.startswith(CLIENT_NODE_PREFIX)
    finally:
        await w.close()
        probe.close()


# ---------------------------------------------------------------- shutdown / reboot
@pytest.fixture
async def secured(make_server, tmp_path):
    secret = tmp_path / "secret"
    secret.write_text(SECRET + "\n")
    server = await make_server(robot="sim", sim_speed=4.0, authenticate=True,
                               auth_secret_file=str(secret))
    watchers: list[Watcher] = []

    async def connect(level: str) -> Watcher:
        w = await Watcher.open(server.port)
        await w.client.send(auth_op(level))
        watchers.append(w)
        return w

    yield server, connect
    for w in watchers:
        await w.close()


async def test_shutdown_needs_admin_and_takes_the_robot_offline(secured):
    server, connect = secured
    user = await connect("user")
    await command(user, "shutdown", "s")
    status = await status_for(user, "s")
    assert status["level"] == "error" and "admin" in status["msg"]
    await command(user, "reboot", "r")
    assert "admin" in (await status_for(user, "r"))["msg"]
    assert server.robot.link.connected

    admin = await connect("admin")
    await admin.subscribe("/diagnostics_agg")
    await command(admin, "shutdown", "s")

    def connection() -> int | None:
        msg = admin.latest("/diagnostics_agg")
        return next((s["level"] for s in msg["status"] if s["name"] == "/Robot/Connection"),
                    None) if msg else None

    await admin.until(lambda: connection() == 2, 4, "/Robot/Connection ERROR")
    assert not server.robot.link.connected
    await asyncio.sleep(0.5)
    assert not server.robot.link.connected  # and it stays off
    await command(admin, "reboot", "r2")  # an offline robot cannot be rebooted
    assert "not connected" in (await status_for(admin, "r2"))["msg"]


async def test_reboot_keeps_what_the_robot_stores_and_starts_in_navigation(make_server):
    """A reboot takes the robot offline; it comes back with what it keeps (its state folder:
    map, lines, pose) and in its start-up mode (mapping off)."""
    server = await make_server(robot="sim", sim_speed=4.0)
    server.robot.link.runner.reboot_delay = 0.5
    w = await Watcher.open(server.port)
    try:
        await w.subscribe("/robot_pose")
        await w.subscribe("/ros_mode")
        await w.until(lambda: w.latest("/robot_pose"), 5, "a pose")
        await w.publish("/initialpose", {"header": {"frame_id": "map"}, "pose": {"pose": {
            "position": {"x": 6.0, "y": 9.0, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}},
            "geometry_msgs/PoseWithCovarianceStamped")
        await command(w, "gmapping")
        await w.until(lambda: w.latest("/robot_pose")["position"]["x"] == 6.0, 3, "moved")
        await w.until(lambda: w.latest("/ros_mode")["data"] == "gmapping", 3, "mapping")
        await command(w, "reboot", "r")
        await w.until(lambda: not server.robot.link.connected, 2, "the robot offline")
        await w.until(lambda: server.robot.link.connected, 5, "the robot back")

        def where_it_was() -> bool:
            p = w.latest("/robot_pose")["position"]
            return math.hypot(p["x"] - 6.0, p["y"] - 9.0) < 0.2

        await w.until(where_it_was, 3, "the pose it had")
        await w.until(lambda: w.latest("/ros_mode")["data"] == "navigation", 3,
                      "the start-up mode")
        assert not [s for s in w.statuses if s.get("id") == "r" and s["level"] == "error"]
    finally:
        await w.close()

"""A whole session recorded by a real server (a fleet of two simulated robots: POIs, a fleet
dispatch, a move_base goal to arrival, a patrol; TF, maps, diagnostics all along) replays in
``hitrobot-server replay``: every recorded channel is accepted, and a client subscribed to every
replayed topic receives each of them."""

from __future__ import annotations

import asyncio
import contextlib
import logging

import pytest
from mcap.reader import make_reader

from hitrobot_server.record.reading import NOT_REPLAYED
from hitrobot_server.robot.options import RobotEntry
from tests.helpers import ServerProcess, Watcher
from tests.nodes.fleet.test_node import POI_T, Y, dispatch, idle, pose, task

EXPECTED_TYPES = {
    "move_base_msgs/msg/MoveBaseActionResult",  # the result the issue found refused
    "move_base_msgs/msg/MoveBaseActionFeedback",
    "actionlib_msgs/msg/GoalStatusArray",
    "action_msgs/msg/GoalStatusArray",  # nav2's compute_path_to_pose, run by the dispatch
    "tf2_msgs/msg/TFMessage",
    "nav_msgs/msg/OccupancyGrid",
    "diagnostic_msgs/msg/DiagnosticArray",
    "hitrobot_msgs/msg/FleetTasks",
    "hitrobot_msgs/msg/FleetRobots",
    "map_messages/msg/PointsOfInterest",
    "rosgraph_msgs/msg/Log",
    "hitrobot_msgs/msg/PatrolState",
}


async def record_session(make_server, tmp_path):
    path = tmp_path / "session.mcap"
    server = await make_server(
        robots=(RobotEntry("a", "sim", (4.0, Y, 0.0)), RobotEntry("b", "sim", (12.0, Y, 0.0))),
        map_dir=str(tmp_path / "maps"), sim_speed=3.0, record=str(path),
        record_dir=str(tmp_path))
    w = await Watcher.open(server.port)
    try:
        for topic in ("/fleet/robots", "/fleet/tasks", "/map_manager/pois", "/a/move_base/result",
                      "/a/planning/patrol_state"):
            await w.subscribe(topic)
        await w.until(lambda: len(idle(w)) == 2, 15, "both robots idle")
        await w.publish("/map_manager/add_poi",
                        {"type": 100, "name": "east", "remarks": "", "pose": pose(14.0, Y)},
                        POI_T)
        await w.until(lambda: "east" in {p["name"] for p in (
            w.latest("/map_manager/pois") or {"pois": []})["pois"]}, 20, "the POI east")
        sent = await dispatch(w, "east")
        await w.until(lambda: (task(w, sent["task"]) or {}).get("state") == "succeeded", 30,
                      "the dispatched robot arriving")
        await w.publish("/a/move_base_simple/goal", {"header": {"frame_id": "map"},
                                                     "pose": pose(6.0, Y)},
                        "geometry_msgs/PoseStamped")
        await w.until(lambda: w.latest("/a/move_base/result"), 30, "a's move_base result")
        waypoints = [{"frame": "map", "x": x, "y": Y, "z": 0.0, "use_z": False}
                     for x in (5.0, 4.0)]
        assert (await w.call("/a/planning/set_waypoints",
                             {"waypoints": waypoints}))["values"]["success"]
        assert (await w.call("/a/planning/start_patrol"))["values"]["success"]
        await w.until(lambda: (w.latest("/a/planning/patrol_state") or {}).get("active"), 10,
                      "the patrol running")
        assert (await w.call("/a/planning/stop_patrol"))["values"]["success"]
    finally:
        await w.close()
        await server.stop()  # the recording finished with its summary
    return path


def channels(path) -> dict[str, str]:
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    return {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}


@pytest.mark.timeout(300)  # a fleet's session recorded, then replayed: ~100 s on a busy CI box
async def test_a_recorded_session_replays_every_topic(make_server, tmp_path, caplog):
    # the server's log at the CLI's default level (info), so /rosout carries its lines as a
    # real server's does (pytest leaves the package's loggers at warning)
    caplog.set_level(logging.INFO, logger="hitrobot_server")
    path = await record_session(make_server, tmp_path)
    recorded = channels(path)
    missing = EXPECTED_TYPES - set(recorded.values())
    assert not missing, f"not recorded: {missing}"
    topics = sorted(t for t in recorded if t not in NOT_REPLAYED)
    server = await asyncio.to_thread(ServerProcess, "--speed", "4", "--loop",
                                     command=("replay", str(path)))
    try:
        w = await Watcher.open(server.port)
        try:
            for topic in topics:  # as the console does: a map at most twice a second
                await w.subscribe(topic, throttle_rate=500, queue_length=1)
            silent = lambda: [t for t in topics if not w.messages.get(t)]  # noqa: E731
            with contextlib.suppress(AssertionError):
                await w.until(lambda: not silent(), 60, "a message on every replayed topic")
            assert not silent(), f"no message on {silent()} of {len(topics)} topics"
            assert not [s for s in w.statuses if s.get("level") == "error"], w.statuses
        finally:
            await w.close()
    finally:
        server.stop()
    log = "".join(server.output) + server.proc.stdout.read()
    assert "alien" not in log and "cannot be decoded" not in log, log

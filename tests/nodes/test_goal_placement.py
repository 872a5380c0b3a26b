"""Goals and patrol waypoints placed like POIs (issue 46, friction 6): an API client's goal on
an obstacle is refused before the robot moves, by every interface that drives it, with one line
naming the problem; a patrol with a waypoint on one is refused; free ones still work. Real
clients (roslibpy's actionlib client, raw rosbridge over a WebSocket) on real servers."""

from __future__ import annotations

import math
import threading
import time

import roslibpy

try:  # roslibpy 1.x
    from roslibpy.actionlib import ActionClient, Goal, GoalStatus
except ImportError:  # roslibpy 2.x
    from roslibpy.ros1.actionlib import ActionClient, Goal, GoalStatus

from hitrobot_server.nodes.ground.placement import cells_of, placement_problem
from tests.helpers import ServerProcess, WsClient, connect_roslibpy
from tests.nodes.map_manager.util import NS, OBSTACLE, current, modify_map, rect, start

DESK = (9.75, 2.2)  # inside the office's desk
ON_DESK = "goal (9.75, 2.20) is on an obstacle"
FREE = (7.0, 8.0)  # two metres along the corridor from the start (5, 8)


def waited(predicate, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not predicate():
        time.sleep(0.02)
    return bool(predicate())


def problem_at(grid: dict | None, x: float, y: float) -> str:
    """What the placement rule says of a goal at (x, y) on a /map message ('' when free)."""
    return placement_problem(cells_of(grid), x, y, known=False) or ""


def target(x: float, y: float) -> roslibpy.Message:
    return roslibpy.Message({"target_pose": {"header": {"frame_id": "map"}, "pose": {
        "position": {"x": x, "y": y, "z": 0.0},
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}})


def test_roslibpy_goal_on_a_desk_is_rejected_at_once_and_the_robot_stays():
    """roslibpy's ActionClient: the goal is REJECTED with the problem as its text, the
    robot's pose does not change; a free goal then arrives."""
    proc = ServerProcess("--sim-speed", "4", robot="sim")
    ros = connect_roslibpy(proc.port)
    lock, seen = threading.Lock(), {}

    def keep(name):
        def got(msg):
            with lock:
                seen[name] = msg
        return got

    roslibpy.Topic(ros, "/map", "nav_msgs/OccupancyGrid").subscribe(keep("map"))
    odoms: list[dict] = []
    roslibpy.Topic(ros, f"{NS}/odom", "nav_msgs/Odometry").subscribe(odoms.append)
    try:
        assert waited(lambda: "obstacle" in problem_at(seen.get("map"), *DESK), 30), \
            "the desk never showed on /map"
        assert waited(lambda: odoms, 10)
        start_at = odoms[-1]["pose"]["pose"]["position"]
        client = ActionClient(ros, "/move_base", "move_base_msgs/MoveBaseAction")
        refused = Goal(client, target(*DESK))
        refused.send()
        assert refused.wait(10) == {}
        assert refused.status["status"] == GoalStatus.REJECTED, refused.status
        assert refused.status["text"] == ON_DESK, refused.status
        count = len(odoms)  # ten odometry messages on (0.5 s): it would be moving by then
        assert waited(lambda: len(odoms) >= count + 10, 10)
        now = odoms[-1]["pose"]["pose"]["position"]
        assert math.dist((now["x"], now["y"]), (start_at["x"], start_at["y"])) < 0.02

        free = Goal(client, target(*FREE))
        free.send()
        free.wait(60)
        assert free.status["status"] == GoalStatus.SUCCEEDED, free.status
        client.dispose()
    finally:
        ros.close()
        proc.stop()


async def test_every_interface_refuses_the_desk_and_the_robot_stays(make_server, tmp_path):
    """Raw rosbridge: /intelligent_navigate_to_pose ends at once (status 6, the problem as
    text), send_action_goal on /move_base is aborted with it, the Slamware move_to_locations
    names the location; the robot has not moved; a free intelligent goal arrives."""
    server, w = await start(make_server, tmp_path / "maps")
    c = await WsClient.open(server.port)
    await w.until(lambda: "obstacle" in problem_at(w.latest("/map"), *DESK), 20, "the desk")
    here = current(w)
    goal = {"pose": {"header": {"frame_id": "map"}, "pose": {
        "position": {"x": DESK[0], "y": DESK[1], "z": 0.0},
        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}
    await c.send({"op": "send_action_goal", "id": "in", "args": goal,
                         "action": "/intelligent_navigate_to_pose",
                         "action_type": "daystar_navigation_msgs/action/IntelligentNavitateToPose"})
    got = await c.expect(op="action_result", id="in", timeout=5)
    assert got["status"] == 6 and got["result"] is False and got["values"] == ON_DESK, got
    await c.send({"op": "send_action_goal", "id": "mb", "action": "/move_base",
                         "action_type": "move_base_msgs/action/MoveBase",
                         "args": {"target_pose": goal["pose"]}})
    got = await c.expect(op="action_result", id="mb", timeout=5)
    assert got["status"] == 6 and got["values"] == ON_DESK, got
    await w.publish(f"{NS}/move_to_locations", {
        "locations": [{"x": FREE[0], "y": FREE[1], "z": 0.0},
                      {"x": DESK[0], "y": DESK[1], "z": 0.0}],
        "options": {"opt_flags": {"flags": 0}, "speed_ratio": {"is_valid": False, "value": 0.0}},
        "yaw": 0.0}, "slamware_ros_sdk/MoveToLocationsRequest", op_id="ml")
    said = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "ml"), None),
                         5, "move_to_locations refused")
    assert said["level"] == "error", said
    assert said["msg"].endswith("move_to_locations: location 1 (9.75, 2.20) is on an obstacle")
    assert math.dist(current(w)[:2], here[:2]) < 0.02  # nothing moved the robot

    free = {**goal, "pose": {**goal["pose"], "pose": {**goal["pose"]["pose"], "position": {
        "x": FREE[0], "y": FREE[1], "z": 0.0}}}}
    await c.send({"op": "send_action_goal", "id": "ok", "args": free,
                         "action": "/intelligent_navigate_to_pose",
                         "action_type": "daystar_navigation_msgs/action/IntelligentNavitateToPose"})
    got = await c.expect(op="action_result", id="ok", timeout=60)
    assert got["status"] == 4 and got["values"]["result"] is True, got
    await c.close()
    await w.close()


def waypoint(x: float, y: float) -> dict:
    return {"frame": "map", "x": x, "y": y, "z": 0.0, "use_z": False}


async def test_a_waypoint_on_an_obstacle_refuses_the_route_and_the_patrol(make_server,
                                                                         tmp_path):
    """set_waypoints and append_waypoint refuse a waypoint on the desk (nothing stored); a
    route whose waypoint an obstacle mask now covers is refused at start_patrol, the robot
    standing; with the mask gone the same route patrols."""
    _server, w = await start(make_server, tmp_path / "maps")
    await w.subscribe("/planning/patrol_state", "hitrobot_msgs/PatrolState")
    await w.until(lambda: "obstacle" in problem_at(w.latest("/map"), *DESK), 20, "the desk")
    here = current(w)
    bad = await w.call("/planning/set_waypoints", {"waypoints": [waypoint(6.0, 8.0),
                                                                 waypoint(*DESK)]})
    assert bad["values"] == {"success": False,
                             "message": "waypoint 1 (9.75, 2.20) is on an obstacle"}, bad
    good = await w.call("/planning/set_waypoints", {"waypoints": [waypoint(6.0, 8.0),
                                                                  waypoint(*FREE)]})
    assert good["values"]["success"], good
    appended = await w.call("/planning/append_waypoint", {"waypoint": waypoint(*DESK)})
    assert not appended["values"]["success"], appended
    assert appended["values"]["message"] == "waypoint 2 (9.75, 2.20) is on an obstacle"
    assert len(w.latest("/planning/patrol_state")["waypoints"]) == 2  # nothing stored

    masked = await modify_map(w, "mask", rect(6.8, 7.8, 7.2, 8.2), OBSTACLE)
    assert masked["level"] == "info", masked
    await w.until(lambda: "obstacle" in problem_at(w.latest("/map"), *FREE), 10, "the mask")
    refused = await w.call("/planning/start_patrol")
    assert refused["values"] == {"success": False, "message": (
        "patrol refused: waypoint 1 (7.00, 8.00) is on an obstacle")}, refused
    assert not w.latest("/planning/patrol_state")["active"]
    assert math.dist(current(w)[:2], here[:2]) < 0.02

    cleared = await modify_map(w, "unmask", rect(6.8, 7.8, 7.2, 8.2), -1)
    assert cleared["level"] == "info", cleared
    await w.until(lambda: not problem_at(w.latest("/map"), *FREE), 10, "no mask")
    started = await w.call("/planning/start_patrol")
    assert started["values"]["success"], started
    await w.until(lambda: any(m["message"] == "reached waypoint 1" for _t, m in
                              w.messages["/planning/patrol_state"]), 60, "waypoint 1 reached")
    await w.call("/planning/stop_patrol")
    await w.close()

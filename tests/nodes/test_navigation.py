"""``/navigation`` (StartNavigation, NavigateToPOI, TargetUnreachable) on a real server with the
simulated robot, and the map manager's masks as the robot's planner sees them."""

from __future__ import annotations

import math

from hitrobot_server.nodes.ground.placement import cells_of, placement_problem
from hitrobot_server.nodes.navigation import (
    LASER_OBSTACLE,
    STALL_OCCURED,
    TILT_OCCURED,
    UNKNOWN,
    planning_area,
    unreachable_reason,
)
from tests.helpers import Watcher, WsClient
from tests.nodes.map_manager.util import (
    BLOCKED,
    MM,
    NOT_MASKED,
    NS,
    current,
    modify_map,
    poi,
    pose,
    rect,
    request,
    start,
    still,
)

NAV = "/navigation"
START_T = "map_messages/StartNavigation"
POI_T = "map_messages/NavigateToPOI"
UNREACHABLE = f"{NAV}/target_unreachable"


def start_msg(x: float, y: float, yaw: float = 0.0, distance: float = 0.0,
              skip_final_turn: bool = False, fast_planning: bool = False) -> dict:
    return {"goal": pose(x, y, yaw), "distance_to_target": distance,
            "skip_final_turn": skip_final_turn, "fast_planning": fast_planning}


def test_unreachable_reasons_and_planning_area():
    assert unreachable_reason("no path to the target") == UNKNOWN
    assert unreachable_reason("robot is stuck") == STALL_OCCURED
    assert unreachable_reason("blocked by an obstacle") == LASER_OBSTACLE
    assert unreachable_reason("the robot is inside an obstacle") == LASER_OBSTACLE
    assert unreachable_reason("Tilt detected") == TILT_OCCURED
    area = planning_area((5.0, 8.0), (3.0, 12.0), margin=1.0)
    assert (area.x, area.y, area.width, area.height) == (2.0, 7.0, 4.0, 6.0)


async def test_navigate_to_poi_arrives_and_turns(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path)
    await request(w, f"{MM}/add_poi", "map_messages/PointOfInterest",
                  poi("office B", 10.0, 12.5, math.pi / 2), "add")
    status = await request(w, f"{NAV}/navigate_to_poi", POI_T,
                           {"poi_name": "office B", "distance_to_target": 0.0,
                            "skip_final_turn": False}, "go", timeout=60)
    assert status["level"] == "info" and "arrived" in status["msg"], status
    await w.until(lambda: still(w), 5, "the robot at rest")
    x, y, yaw = current(w)
    assert math.hypot(x - 10.0, y - 12.5) < 0.2
    assert abs(math.remainder(yaw - math.pi / 2, 2 * math.pi)) < 0.1
    assert UNREACHABLE not in w.messages
    # refused requests
    for op_id, topic, type_name, msg, needle in [
        ("no-poi", f"{NAV}/navigate_to_poi", POI_T,
         {"poi_name": "nowhere", "distance_to_target": 0.0, "skip_final_turn": False},
         "no POI named 'nowhere'"),
        ("negative", f"{NAV}/start", START_T, start_msg(5.0, 8.0, distance=-1.0),
         "must not be negative"),
        ("nan", f"{NAV}/start", START_T, dict(start_msg(5.0, 8.0), distance_to_target=None),
         "distance_to_target"),
    ]:
        status = await request(w, topic, type_name, msg, op_id)
        assert status["level"] == "error" and needle in status["msg"], status
    await w.close()


async def test_fast_planning_box_and_distance_to_target(make_server, tmp_path):
    """Office A's door lies west of the robot-goal box: fast planning cannot get there, the
    full planner can; ``distance_to_target`` ends the trip early, without the final turn."""
    _server, w = await start(make_server, tmp_path)
    await w.subscribe(UNREACHABLE, "map_messages/TargetUnreachable")
    status = await request(w, f"{NAV}/start", START_T,
                           start_msg(5.0, 12.0, fast_planning=True), "fast", timeout=30)
    assert status["level"] == "error" and "target unreachable" in status["msg"], status
    got = await w.until(lambda: w.latest(UNREACHABLE), 5, "TargetUnreachable")
    assert got["reason"] == UNKNOWN
    start_x, start_y, _ = current(w)
    assert math.hypot(start_x - 5.0, start_y - 8.0) < 0.3  # it never left the corridor
    status = await request(w, f"{NAV}/start", START_T,
                           start_msg(5.0, 12.0, yaw=math.pi, distance=0.6,
                                     skip_final_turn=True), "full", timeout=60)
    assert status["level"] == "info" and "arrived" in status["msg"], status
    x, y, yaw = current(w)
    assert 0.3 < math.hypot(x - 5.0, y - 12.0) < 0.75  # stopped at about the given distance
    assert abs(math.remainder(yaw - math.pi, 2 * math.pi)) > 0.3  # and did not turn
    assert len(w.messages[UNREACHABLE]) == 1
    await w.close()


def path_points(w) -> list[tuple[float, float]]:
    plan = w.latest(f"{NS}/global_plan_path") or {}
    return [(p["pose"]["position"]["x"], p["pose"]["position"]["y"])
            for p in plan.get("poses", [])]


def crossings(route: list[tuple[float, float]], y: float) -> list[float]:
    """x where the polyline crosses the horizontal line at ``y``."""
    out = []
    for (x0, y0), (x1, y1) in zip(route, route[1:], strict=False):
        if (y0 - y) * (y1 - y) < 0:
            out.append(x0 + (x1 - x0) * (y - y0) / (y1 - y0))
    return out


async def test_blocked_mask_across_a_door_changes_the_path(make_server, tmp_path):
    """From the corridor into the open-plan area: through its west door, until a BLOCKED mask
    closes that door; then the planner takes another way, and the robot still arrives."""
    _server, w = await start(make_server, tmp_path)
    await w.subscribe(f"{NS}/global_plan_path")
    goal = start_msg(11.75, 3.5, skip_final_turn=True)
    await w.client.send({"op": "advertise", "topic": f"{NAV}/start", "type": START_T})
    await w.publish(f"{NAV}/start", goal, op_id="free")
    free = await w.until(lambda: path_points(w), 20, "a plan")
    route = [current(w)[:2], *free]
    assert any(9.0 <= x <= 10.0 for x in crossings(route, 6.92)), route  # the west door
    await w.publish(f"{NS}/cancel_action", {}, "slamware_ros_sdk/CancelActionRequest")
    await w.until(lambda: still(w) and not path_points(w), 10, "the robot stopped")

    door = (8.8, 6.5, 10.2, 7.4)
    status = await modify_map(w, "close", rect(*door), BLOCKED)
    assert status["level"] == "info", status
    seen = len(w.messages[f"{NS}/global_plan_path"])
    origin = current(w)[:2]
    status = await request(w, f"{NAV}/start", START_T, goal, "masked", timeout=90)
    assert status["level"] == "info" and "arrived" in status["msg"], status
    plans = [[(p["pose"]["position"]["x"], p["pose"]["position"]["y"]) for p in m["poses"]]
             for _t, m in w.messages[f"{NS}/global_plan_path"][seen:]]
    first = next(plan for plan in plans if plan)
    route = [origin, *first]
    doors = crossings(route, 6.92)
    assert doors and not any(9.0 <= x <= 10.0 for x in doors), route
    for plan in plans:  # the whole way, no plan ever entered the masked area
        assert not any(door[0] <= x <= door[2] and door[1] <= y <= door[3] for x, y in plan)
    x, y, _ = current(w)
    assert math.hypot(x - 11.75, y - 3.5) < 0.3
    await w.close()


async def test_goal_closed_off_by_a_mask_is_unreachable(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path)
    await w.subscribe(UNREACHABLE, "map_messages/TargetUnreachable")
    await modify_map(w, "door", rect(8.2, 8.7, 9.5, 9.5), BLOCKED)  # office B's door
    status = await request(w, f"{NAV}/start", START_T, start_msg(10.0, 12.5), "boxed",
                           timeout=30)
    assert status["level"] == "error" and "no path" in status["msg"], status
    assert (await w.until(lambda: w.latest(UNREACHABLE), 5, "TargetUnreachable"))["reason"] == (
        UNKNOWN)
    # a mask around the robot itself: it is inside an obstacle
    x, y, _ = current(w)
    await modify_map(w, "around", rect(x - 1.0, y - 0.8, x + 1.0, y + 0.8), BLOCKED)
    status = await request(w, f"{NAV}/start", START_T, start_msg(3.0, 8.0), "inside",
                           timeout=30)
    assert status["level"] == "error" and "inside an obstacle" in status["msg"], status
    await w.until(lambda: len(w.messages[UNREACHABLE]) == 2, 5, "a second TargetUnreachable")
    assert w.latest(UNREACHABLE)["reason"] == LASER_OBSTACLE
    # unmasking opens the way again
    await modify_map(w, "open", rect(0.0, 0.0, 24.0, 16.0), NOT_MASKED)
    await w.subscribe(f"{NS}/global_plan_path")
    await w.client.send({"op": "advertise", "topic": f"{NAV}/start", "type": START_T})
    await w.publish(f"{NAV}/start", start_msg(10.0, 12.5))
    await w.until(lambda: path_points(w), 20, "a plan into office B")
    await w.close()


DESK = (9.75, 2.2)
"""A goal inside a desk: the nearest spot the robot can park on is about 1 m away."""


async def test_a_goal_inside_furniture_is_unreachable_on_every_interface(start_robot):
    """No interface reports an arrival 1 m off, and none drives there first (issue 46): the
    planner's compute_path_to_pose fails, and every interface that moves the robot refuses the
    goal at once by the POIs' placement rule, naming the problem: the Slamware move_to,
    map_messages (TargetUnreachable with a reason) and /move_base (REJECTED, one line to its
    publisher); the robot has not moved, and it drives on afterwards."""
    server = await start_robot(sim_speed=4.0)
    w = await Watcher.open(server.port)
    await w.client.send({"op": "set_level", "level": "info"})
    await w.subscribe(f"{NS}/odom", "nav_msgs/Odometry")
    await w.subscribe(UNREACHABLE)
    await w.subscribe("/move_base/result")
    await w.subscribe("/map", "nav_msgs/OccupancyGrid")
    await w.until(lambda: w.latest(f"{NS}/odom"), 10, "odometry")
    await w.until(lambda: "obstacle" in (placement_problem(
        cells_of(w.latest("/map")), *DESK, known=False) or ""), 20, "the desk on /map")
    c = await WsClient.open(server.port)
    try:
        await c.send({"op": "send_action_goal", "id": "plan", "action": "/compute_path_to_pose",
                      "action_type": "nav2_msgs/action/ComputePathToPose",
                      "args": {"goal": {"header": {"frame_id": "map"}, "pose": pose(*DESK)},
                               "use_start": False}})
        res = await c.expect(op="action_result", id="plan", timeout=20)
        assert res["status"] == 6 and res["result"] is False, res
        assert "inside an obstacle" in res["values"]

        start_xy = current(w)[:2]
        on_desk = f"goal ({DESK[0]:.2f}, {DESK[1]:.2f}) is on an obstacle"
        await w.publish(f"{NS}/move_to", {"location": {"x": DESK[0], "y": DESK[1], "z": 0.0},
                                          "options": {"opt_flags": {"flags": 64},
                                                      "speed_ratio": {"is_valid": False,
                                                                      "value": 0.0}},
                                          "yaw": 0.0}, "slamware_ros_sdk/MoveToRequest",
                        op_id="direct")
        status = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "direct"),
                                            None), 20, "move_to refused")
        assert status["level"] == "error" and on_desk in status["msg"], status

        await w.publish(f"{NAV}/start", start_msg(*DESK, distance=0.2), START_T, op_id="nav")
        got = await w.until(lambda: w.latest(UNREACHABLE), 20, "TargetUnreachable")
        assert got["reason"] == LASER_OBSTACLE
        status = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "nav"),
                                            None), 10, "the navigation's status")
        assert status["level"] == "error" and "unreachable" in status["msg"], status
        assert on_desk in status["msg"], status

        await w.publish("/move_base/goal", {
            "goal_id": {"id": "desk"},
            "goal": {"target_pose": {"header": {"frame_id": "map"}, "pose": pose(*DESK)}}},
            "move_base_msgs/MoveBaseActionGoal", op_id="mb")

        def result():
            return next((m["status"] for _t, m in w.messages.get("/move_base/result", [])
                         if m["status"]["goal_id"]["id"] == "desk"), None)
        done = await w.until(result, 20, "the move_base result")
        assert done["status"] == 5 and done["text"] == on_desk, done  # REJECTED
        said = [s for s in w.statuses if s.get("id") == "mb"]
        assert [s["msg"] for s in said] == [
            f"publish to '/move_base/goal': {on_desk}"], said  # one line, no goal id
        assert math.dist(current(w)[:2], start_xy) < 0.05  # it never left

        await w.publish(f"{NAV}/start", start_msg(7.0, 8.0, distance=0.2), START_T,
                        op_id="away")
        status = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "away"),
                                            None), 60, "driving away")
        assert status["level"] == "info" and "arrived" in status["msg"], status
        assert math.dist(current(w)[:2], (7.0, 8.0)) < 0.25
    finally:
        await c.close()
        await w.close()

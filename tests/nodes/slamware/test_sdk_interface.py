"""The simulated robot through the slamware_ros_sdk_server_node interface, over real WebSockets.

Every test starts a real server on loopback with the built-in simulator (running faster than
real time) and drives it only through the protocol, as a client of the real node would. Each
test runs twice: with the simulator in process (``sim``), and with the simulator behind a
sim-device on an ephemeral loopback port that the server drives over the Slamware REST API
(``rest``), so the REST client is held to the same acceptance tests.
"""

from __future__ import annotations

import asyncio
import base64
import math

import numpy as np
import pytest

from hitrobot_server.nodes.ground.messages import yaw_of
from hitrobot_server.robot.sim.world import load_world
from tests.helpers import Watcher
from tests.nodes.robot_setup import RobotSetup

NS = "/slamware_ros_sdk_server_node"
PRECISE_WITH_YAW = 16 | 32
NO_SPEED = {"is_valid": False, "value": 0.0}
SPEED = 4.0  # simulated seconds per wall second


def options(flags: int = 0) -> dict:
    return {"opt_flags": {"flags": flags}, "speed_ratio": NO_SPEED}


@pytest.fixture(scope="module")
def world():
    return load_world()


# odom and basic state watched, on both backends
ROBOT = RobotSetup(sim_speed=SPEED,
                   watch={f"{NS}/odom": "nav_msgs/Odometry", f"{NS}/robot_basic_state": None},
                   ready=lambda w: w.latest(f"{NS}/odom"), ready_what="odometry",
                   backends=("sim", "rest"))


def pose_of(odom: dict) -> tuple[float, float, float]:
    p = odom["pose"]["pose"]
    return p["position"]["x"], p["position"]["y"], yaw_of(p["orientation"])


def current(w: Watcher) -> tuple[float, float, float]:
    return pose_of(w.latest(f"{NS}/odom"))


def still(w: Watcher) -> bool:
    twist = w.latest(f"{NS}/odom")["twist"]["twist"]
    return abs(twist["linear"]["x"]) < 1e-3 and abs(twist["angular"]["z"]) < 1e-3


async def arrive(w: Watcher, x: float, y: float, tol: float, timeout: float = 60) -> None:
    await w.until(lambda: math.hypot(current(w)[0] - x, current(w)[1] - y) < tol and still(w),
                  timeout, f"the robot at ({x}, {y})")


def solid_at(world, x: float, y: float) -> bool:
    s = world.spec
    col = int((x - s.origin_x) / s.resolution)
    row = int((y - s.origin_y) / s.resolution)
    return bool(world.solid[row, col])


def clearance(world, x: float, y: float) -> float:
    """Distance from (x, y) to the nearest solid cell, up to 1 m."""
    for d in np.arange(0.0, 1.0, 0.02):
        if any(solid_at(world, x + d * math.cos(a), y + d * math.sin(a))
               for a in np.linspace(0, 2 * math.pi, 48, endpoint=False)):
            return d
    return 1.0


def crosses(p, q, a, b) -> bool:
    """Do segments p-q and a-b intersect?"""
    def orient(o, s, t):
        return (s[0] - o[0]) * (t[1] - o[1]) - (s[1] - o[1]) * (t[0] - o[0])
    return (orient(p, q, a) * orient(p, q, b) < 0) and (orient(a, b, p) * orient(a, b, q) < 0)


async def move_to(w: Watcher, x: float, y: float, yaw: float = 0.0, flags: int = 0,
                  op_id: str | None = None) -> None:
    await w.publish(f"{NS}/move_to", {"location": {"x": x, "y": y, "z": 0.0},
                                      "options": options(flags), "yaw": yaw}, op_id=op_id)


async def test_move_to_precise_with_yaw_reaches_goal_on_a_wall_free_path(robot, world):
    w = robot.w
    await w.subscribe(f"{NS}/global_plan_path")
    goal = (10.0, 12.5, math.pi / 2)  # from the corridor into an office
    assert clearance(world, goal[0], goal[1]) >= 0.5  # a spot the robot can stand on exactly
    await move_to(w, *goal, flags=PRECISE_WITH_YAW)
    path = await w.until(lambda: (w.latest(f"{NS}/global_plan_path") or {}).get("poses"),
                         20, "a planned path")
    points = [(p["pose"]["position"]["x"], p["pose"]["position"]["y"]) for p in path]
    for (x0, y0), (x1, y1) in zip(points, points[1:], strict=False):
        for t in np.linspace(0, 1, max(2, int(math.hypot(x1 - x0, y1 - y0) / 0.02))):
            assert not solid_at(world, x0 + t * (x1 - x0), y0 + t * (y1 - y0))
    await arrive(w, goal[0], goal[1], 0.1)
    x, y, yaw = current(w)
    assert math.hypot(x - goal[0], y - goal[1]) < 0.1
    assert abs(math.remainder(yaw - goal[2], 2 * math.pi)) < 0.1


async def test_virtual_wall_across_corridor_detour_and_enclosed_goal_fails(robot):
    w = robot.w
    await w.subscribe(f"{NS}/global_plan_path")
    await w.subscribe(f"{NS}/virtual_walls")
    wall = ((12.0, 6.9), (12.0, 9.6))
    await w.publish(f"{NS}/add_line", {"usage": {"usage": 0}, "line": {
        "id": 7, "start": {"x": wall[0][0], "y": wall[0][1]},
        "end": {"x": wall[1][0], "y": wall[1][1]}}})
    await w.until(lambda: (w.latest(f"{NS}/virtual_walls") or {}).get("lines"), 5, "the wall")
    await move_to(w, 20.0, 8.2)
    path = await w.until(lambda: (w.latest(f"{NS}/global_plan_path") or {}).get("poses"),
                         20, "a planned path")
    points = [(p["pose"]["position"]["x"], p["pose"]["position"]["y"]) for p in path]
    start = current(w)[:2]
    route = [start, *points]
    assert not any(crosses(a, b, *wall) for a, b in zip(route, route[1:], strict=False))
    assert min(y for _x, y in points) < 6.8  # the detour goes through the open-plan area
    await arrive(w, 20.0, 8.2, 0.3, timeout=90)

    # a goal boxed in by virtual walls cannot be reached: the requester is told why
    box = [((17.2, 7.6), (18.8, 7.6)), ((18.8, 7.6), (18.8, 8.9)),
           ((18.8, 8.9), (17.2, 8.9)), ((17.2, 8.9), (17.2, 7.6))]
    await w.publish(f"{NS}/add_lines", {"usage": {"usage": 0}, "lines": [
        {"id": 20 + i, "start": {"x": a[0], "y": a[1]}, "end": {"x": b[0], "y": b[1]}}
        for i, (a, b) in enumerate(box)]})
    await w.until(lambda: len(w.latest(f"{NS}/virtual_walls")["lines"]) == 5, 5, "the box")
    await move_to(w, 18.0, 8.25, op_id="boxed")
    status = await w.until(
        lambda: next((s for s in w.statuses if s.get("id") == "boxed"), None), 60,
        "a failure status")
    assert status["level"] == "error" and "move_to failed" in status["msg"]


async def test_cancel_action_stops_the_robot(robot):
    w = robot.w
    await move_to(w, 20.0, 8.2)
    await w.until(lambda: w.latest(f"{NS}/odom")["twist"]["twist"]["linear"]["x"] > 0.1, 20,
                  "the robot moving")
    await w.publish(f"{NS}/cancel_action", {})
    await w.until(lambda: still(w), 5, "the robot stopped")
    stopped = current(w)
    await asyncio.sleep(0.5)
    assert math.hypot(current(w)[0] - stopped[0], current(w)[1] - stopped[1]) < 0.02
    assert current(w)[0] < 19.0


async def test_go_home_docks_and_charges(robot):
    w = robot.w
    await w.publish(f"{NS}/go_home", {})
    state = await w.until(
        lambda: (w.latest(f"{NS}/robot_basic_state") or {}).get("is_charging") and
        w.latest(f"{NS}/robot_basic_state"), 90, "charging on the dock")
    assert state["is_dc_in"] is True
    x, y, _yaw = current(w)
    assert math.hypot(x - 3.5, y - 0.55) < 0.2


async def test_scan_matches_the_known_geometry(robot, world):
    w = robot.w
    await w.subscribe(f"{NS}/scan")
    scan = await w.next(f"{NS}/scan")
    x, y, yaw = current(w)  # the robot stands still at its start pose, localized
    assert len(scan["ranges"]) == 360 and abs(scan["angle_min"] + math.pi) < 1e-6
    measured = np.array([np.inf if r is None else r for r in scan["ranges"]])
    expected = []
    for i in range(360):
        a = yaw + scan["angle_min"] + i * scan["angle_increment"]
        for d in np.arange(0.05, 12.0, 0.01):  # our own ray march, not the simulator's
            if solid_at(world, x + d * math.cos(a), y + d * math.sin(a)):
                expected.append(d)
                break
        else:
            expected.append(np.inf)
    expected = np.array(expected)
    both = np.isfinite(measured) & np.isfinite(expected)
    assert both.sum() > 300
    error = np.abs(measured[both] - expected[both])
    assert np.median(error) < 0.05 and np.percentile(error, 90) < 0.15


async def synced_map(w: Watcher) -> dict:
    """The map as the node publishes it after a full sync: sync_map is handled once the call
    after it is answered; the sync runs at the next map update tick, so wait for map messages
    newer than that until two in a row agree (a sync in progress publishes a partial map)."""
    topic = f"{NS}/map"
    await w.publish(f"{NS}/sync_map", {})
    await w.call("/rosapi/get_time")
    after = len(w.messages.get(topic, []))

    def settled() -> dict | None:
        got = [msg for _t, msg in w.messages.get(topic, [])[after:]]
        if len(got) >= 4 and got[-1]["data"] == got[-2]["data"]:
            return got[-1]
        return None

    return await w.until(settled, 20, "a settled map after sync_map")


async def test_map_grows_while_mapping_and_freezes_when_disabled(start_robot):
    server = await start_robot(sim_speed=SPEED, sim_mapping=True)
    w = await Watcher.open(server.port)
    await w.subscribe(f"{NS}/map", "nav_msgs/OccupancyGrid")
    await w.subscribe(f"{NS}/odom")

    def known() -> int:
        grid = w.latest(f"{NS}/map")
        return sum(1 for v in grid["data"] if v != -1) if grid else 0

    await w.until(known, 10, "a first map")
    first = known()
    await move_to(w, 14.0, 8.2)
    await w.until(lambda: known() > first * 1.5, 60, "the map to grow")
    await w.publish(f"{NS}/set_map_update", {"enabled": False, "kind": {"kind": 0}})
    await w.subscribe(f"{NS}/robot_basic_state")
    await w.call("/rosapi/get_time")  # both ops handled: what follows is newer state
    w.messages.pop(f"{NS}/robot_basic_state", None)
    await w.until(lambda: (w.latest(f"{NS}/robot_basic_state") or {})
                  .get("is_map_building_enabled") is False, 10, "map building disabled")
    # the node's copy refreshes only a window around the robot (as the real node's does), so
    # compare full syncs of the robot's map before and after more driving
    frozen = await synced_map(w)
    await move_to(w, 20.0, 8.2)
    await w.until(lambda: w.latest(f"{NS}/odom") and current(w)[0] > 17.0, 60, "more driving")
    assert (await synced_map(w))["data"] == frozen["data"]
    state = (await w.call("/rosapi/get_time"))  # the bus still answers while the robot moves
    assert state["result"] is True
    await w.close()


async def test_stcm_round_trip_restores_the_map(robot):
    w = robot.w
    await w.subscribe(f"{NS}/map", "nav_msgs/OccupancyGrid")
    original = await w.until(lambda: w.latest(f"{NS}/map"), 10, "the map")
    saved = await w.call(f"{NS}/sync_get_stcm")
    assert saved["result"] is True and len(saved["values"]["raw_stcm"]) > 100
    await w.publish(f"{NS}/clear_map", {"kind": {"kind": 0}})
    cleared = await w.call(f"{NS}/sync_get_stcm")
    assert cleared["values"]["raw_stcm"] != saved["values"]["raw_stcm"]
    x, y, yaw = current(w)
    restored = await w.call(f"{NS}/sync_set_stcm", {
        "raw_stcm": saved["values"]["raw_stcm"],
        "robot_pose": {"position": {"x": x, "y": y, "z": 0.0},
                       "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2),
                                       "w": math.cos(yaw / 2)}}})
    assert restored["result"] is True
    count = len(w.messages[f"{NS}/map"])
    await w.until(lambda: len(w.messages[f"{NS}/map"]) > count + 2, 10, "a resynced map")
    again = w.latest(f"{NS}/map")
    assert again["info"]["width"] == original["info"]["width"]
    assert again["info"]["origin"] == original["info"]["origin"]
    assert again["data"] == original["data"]


def pose_msg(x: float, y: float, yaw: float) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}


async def test_refused_stcm_changes_nothing(robot):
    """A composite map that is too short, or whose checksum is wrong, is refused before the
    robot's map, localization or mapping are touched (the seed's int8[] spelling too)."""
    w = robot.w
    state = f"{NS}/robot_basic_state"
    await w.until(lambda: (w.latest(state) or {}).get("localization_quality", 0) > 60, 10,
                  "good localization")
    saved = (await w.call(f"{NS}/sync_get_stcm"))["values"]["raw_stcm"]
    raw = base64.b64decode(saved)
    corrupt = bytearray(raw)
    corrupt[len(corrupt) // 2] ^= 0xFF
    pose = pose_msg(*current(w))
    for bad, why in (([1, 2, 3], "too short"), ([-1, -2, 3, 4] * 10, "magic"),
                     (base64.b64encode(bytes(corrupt)).decode(), "checksum")):
        reply = await w.call(f"{NS}/sync_set_stcm", {"raw_stcm": bad, "robot_pose": pose})
        assert reply["result"] is False and why in reply["values"], reply
    after = await w.call(f"{NS}/sync_get_stcm")
    assert base64.b64decode(after["values"]["raw_stcm"]) == raw
    fresh = await w.next(state)
    assert fresh["is_localization_enabled"] is True
    assert fresh["localization_quality"] > 60


async def test_clear_map_publishes_the_cleared_map_to_late_subscribers(robot):
    """After clear_map the node's map (and the composed /map) hold no known cell any more,
    also for a client that subscribes only afterwards (the latched copy)."""
    server, w = robot.server, robot.w
    for topic in (f"{NS}/map", "/map"):
        await w.subscribe(topic, "nav_msgs/OccupancyGrid")
        full = await w.until(lambda t=topic: w.latest(t), 10, topic)
        assert any(v != -1 for v in full["data"])
    await w.publish(f"{NS}/clear_map", {"kind": {"kind": 0}})
    for topic in (f"{NS}/map", "/map"):
        await w.until(lambda t=topic: all(v == -1 for v in w.latest(t)["data"]), 10,
                      f"an all-unknown {topic}")
    late = await Watcher.open(server.port)
    try:
        for topic in (f"{NS}/map", "/map"):
            await late.subscribe(topic, "nav_msgs/OccupancyGrid")
            first = await late.until(lambda t=topic: late.latest(t), 10, f"latched {topic}")
            assert all(v == -1 for v in first["data"]), topic
    finally:
        await late.close()


async def test_set_pose_far_away_drops_quality_and_recovery_restores_it(robot):
    w = robot.w
    state = f"{NS}/robot_basic_state"
    await w.until(lambda: (w.latest(state) or {}).get("localization_quality", 0) > 60, 10,
                  "good localization")
    true_x, true_y, true_yaw = current(w)
    await w.client.send({"op": "set_level", "level": "warning"})
    await w.publish(f"{NS}/set_pose", {"position": {"x": 15.0, "y": 12.0, "z": 0.0},
                                       "orientation": {"x": 0.0, "y": 0.0, "z": 0.5,
                                                       "w": math.sqrt(0.75)}}, op_id="far")
    await w.until(lambda: w.latest(state)["localization_quality"] < 30, 15, "quality to drop")
    warned = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "far"), None),
                           15, "set_pose's verdict")
    assert warned["level"] == "warning" and "not converged" in warned["msg"], warned
    await w.publish(f"{NS}/recover_localization", {
        "area": {"x": 0.0, "y": 0.0, "w": 0.0, "h": 0.0},
        "options": {"max_time_ms": {"is_valid": True, "value": 20000},
                    "mvmt_type": {"is_valid": False, "value": {"type": 0}}}})
    await w.until(lambda: w.latest(state)["localization_quality"] > 60, 30, "recovery")
    x, y, _ = current(w)
    assert math.hypot(x - true_x, y - true_y) < 0.3
    await w.client.send({"op": "set_level", "level": "info"})
    await w.publish(f"{NS}/set_pose", pose_msg(x, y, true_yaw), op_id="near")
    fine = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "near"), None),
                         15, "set_pose's verdict")
    assert fine["level"] == "info" and "localized" in fine["msg"], fine


async def test_publish_rates_follow_their_periods(robot):
    w = robot.w
    periods = {f"{NS}/odom": 0.05, f"{NS}/scan": 0.1, f"{NS}/map": 0.2,
               f"{NS}/basic_sensors_values": 0.05, f"{NS}/global_plan_path": 0.05,
               f"{NS}/virtual_walls": 0.5, f"{NS}/robot_basic_state": 1.0}
    for topic in periods:
        if topic not in (f"{NS}/odom", f"{NS}/robot_basic_state"):
            await w.subscribe(topic)
    await w.until(lambda: all(w.messages.get(t) for t in periods), 5, "every topic publishing")
    for topic in periods:
        w.messages[topic] = []
    await asyncio.sleep(4.5)
    for topic, period in periods.items():
        stamps = [t for t, _m in w.messages[topic]]
        assert len(stamps) >= 3, topic
        rate = (len(stamps) - 1) / (stamps[-1] - stamps[0])
        assert abs(rate * period - 1.0) < 0.2, f"{topic}: {rate:.2f} Hz for period {period}"


async def test_invalid_requests_get_status_errors_and_change_nothing(robot):
    w = robot.w
    await w.subscribe(f"{NS}/virtual_walls")
    await w.until(lambda: w.latest(f"{NS}/virtual_walls") is not None, 5, "walls")
    before = current(w)
    bad = {
        "unknown-direction": (f"{NS}/move_by_direction",
                              {"direction": {"direction": -1}, "options": options()}),
        "nan-yaw": (f"{NS}/move_to", {"location": {"x": 6.0, "y": 8.0, "z": 0.0},
                                      "options": options(), "yaw": None}),
        "zero-line": (f"{NS}/add_line", {"usage": {"usage": 0}, "line": {
            "id": 1, "start": {"x": 1.0, "y": 1.0}, "end": {"x": 1.0, "y": 1.0}}}),
        "unknown-usage": (f"{NS}/clear_lines", {"usage": {"usage": -1}}),
        "unknown-line": (f"{NS}/remove_line", {"usage": {"usage": 0}, "id": 999}),
        "bad-flags": (f"{NS}/move_to", {"location": {"x": 6.0, "y": 8.0, "z": 0.0},
                                        "options": options(1 << 20), "yaw": 0.0}),
    }
    for op_id, (topic, msg) in bad.items():
        await w.publish(topic, msg, op_id=op_id)
    for op_id, needle in (("unknown-direction", "direction"), ("nan-yaw", "yaw"),
                          ("zero-line", "zero length"), ("unknown-usage", "usage"),
                          ("unknown-line", "999"), ("bad-flags", "flags")):
        status = await w.until(
            lambda i=op_id: next((s for s in w.statuses if s.get("id") == i), None), 5, op_id)
        assert status["level"] == "error" and needle in status["msg"], status
    for _ in range(2):  # walls and poses the robot reported after the refusals
        await w.next(f"{NS}/virtual_walls", 5)
    await w.next(f"{NS}/odom", 5)
    assert w.latest(f"{NS}/virtual_walls")["lines"] == []
    after = current(w)
    assert math.hypot(after[0] - before[0], after[1] - before[1]) < 0.01


async def test_parameters_tf_and_device_info(start_robot):
    from hitrobot_server.nodes.options import SlamwareParams

    server = await start_robot(slamware=SlamwareParams(scan_pub_period=0.0,
                                                       map_frame="/slamware_map"))
    w = await Watcher.open(server.port)
    got = await w.call("/rosapi/get_param", {"name": f"{NS}/robot_pose_pub_period"})
    assert got["values"]["value"] == "0.05"
    got = await w.call("/rosapi/get_param", {"name": f"{NS}/scan_pub_period"})
    assert got["values"]["value"] == "0.0"
    await w.subscribe(f"{NS}/scan", "sensor_msgs/LaserScan")
    await w.subscribe("/tf")
    await w.subscribe(f"{NS}/robot_device_info")
    tf = await w.next("/tf")
    frames = {(t["header"]["frame_id"], t["child_frame_id"]) for t in tf["transforms"]}
    await w.until(lambda: len({(t["header"]["frame_id"], t["child_frame_id"])
                               for _s, m in w.messages["/tf"] for t in m["transforms"]}) >= 2,
                  5, "both pose transforms")
    frames = {(t["header"]["frame_id"], t["child_frame_id"])
              for _s, m in w.messages["/tf"] for t in m["transforms"]}
    assert ("/slamware_map", "/odom") in frames and ("/odom", "/base_link") in frames
    device = await w.until(lambda: w.latest(f"{NS}/robot_device_info"), 5, "device info")
    assert device["model_name"]
    await asyncio.sleep(1.0)
    assert f"{NS}/scan" not in w.messages  # a period of 0 disables the publisher
    await w.close()


def line(x0: float, y0: float, x1: float, y1: float, line_id: int = 0) -> dict:
    return {"id": line_id, "start": {"x": x0, "y": y0}, "end": {"x": x1, "y": y1}}


async def test_the_seeds_spellings_are_accepted(robot):
    """rotate with ``orientation``, add_lines / move_lines with ``line`` and a subscription
    typed ``BasicSensorValuedataArray`` work as their SDK spellings do; both spellings of one
    field at once are refused, naming both."""
    w = robot.w
    await w.subscribe(f"{NS}/basic_sensors_values", "slamware_ros_sdk/BasicSensorValuedataArray")
    await w.subscribe(f"{NS}/virtual_walls")
    walls = f"{NS}/virtual_walls"
    await w.publish(f"{NS}/add_lines", {"usage": {"usage": 0},
                                        "line": [line(1.0, 1.0, 2.0, 1.0)]},
                    "slamware_ros_sdk/AddLinesRequest", op_id="seed-add")
    got = await w.until(lambda: (w.latest(walls) or {}).get("lines"), 10, "the seed's wall")
    wall_id = got[0]["id"]
    await w.publish(f"{NS}/move_lines", {"usage": {"usage": 0},
                                         "line": [line(1.0, 2.0, 2.0, 2.0, wall_id)]},
                    "slamware_ros_sdk/MoveLinesRequest")
    await w.until(lambda: w.latest(walls)["lines"][0]["start"]["y"] == 2.0, 10, "moved wall")
    start_yaw = current(w)[2]
    half = math.pi / 4  # a quarter turn: quaternion of pi/2
    await w.publish(f"{NS}/rotate", {"orientation": {"x": 0.0, "y": 0.0, "z": math.sin(half),
                                                     "w": math.cos(half)},
                                     "options": options()}, "slamware_ros_sdk/RotateRequest")
    await w.until(lambda: abs(math.remainder(current(w)[2] - start_yaw - math.pi / 2, math.tau))
                  < 0.05 and still(w), 20, "a quarter turn")
    values = await w.until(lambda: w.latest(f"{NS}/basic_sensors_values"), 5, "sensor values")
    assert "values_data" in values
    await w.publish(f"{NS}/rotate", {"orientation": {"x": 0, "y": 0, "z": 0, "w": 1},
                                     "rotation": {"x": 0, "y": 0, "z": 0, "w": 1},
                                     "options": options()}, op_id="both")
    status = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "both"),
                                        None), 5, "a refusal")
    assert status["level"] == "error"
    assert "'orientation'" in status["msg"] and "'rotation'" in status["msg"]
    assert not any(s.get("id") == "seed-add" for s in w.statuses)


async def test_teleop_and_cancel_are_not_errors(robot):
    """move_by_direction at 10 Hz, as a joystick drives: every command but the last is
    superseded by the next, and that is reported at info level, never as an error; so is an
    ordinary cancel of a move."""
    w = robot.w
    await w.client.send({"op": "set_level", "level": "info"})
    ids = [f"joy-{i}" for i in range(10)]
    for op_id in ids:  # the joystick's own 10 Hz pace
        await w.publish(f"{NS}/move_by_direction", {"direction": {"direction": 2},
                                                    "options": options()}, op_id=op_id)
        await asyncio.sleep(0.1)
    finals = {}
    for op_id in ids:
        finals[op_id] = await w.until(
            lambda i=op_id: next((s for s in w.statuses if s.get("id") == i), None), 10, op_id)
    assert all(s["level"] == "info" for s in finals.values()), finals
    assert sum("superseded" in s["msg"] for s in finals.values()) >= 5
    await move_to(w, 20.0, 8.2, op_id="long-move")
    await w.until(lambda: w.latest(f"{NS}/odom")["twist"]["twist"]["linear"]["x"] > 0.1, 20,
                  "the robot moving")
    await w.publish(f"{NS}/cancel_action", {}, op_id="cancel")
    for op_id, needle in (("cancel", "cancelled MoveToAction"), ("long-move", "cancelled")):
        status = await w.until(
            lambda i=op_id: next((s for s in w.statuses if s.get("id") == i), None), 10, op_id)
        assert status["level"] == "info" and needle in status["msg"], status
    assert not [s for s in w.statuses if s["level"] == "error"], w.statuses


async def test_cmd_vel_honours_the_turn_and_stops_soon_after_the_last_command(robot):
    """/cmd_vel at 10 Hz, driving forward while turning: the robot turns as it drives (the
    REST emulation steers too), and it stops within a short distance of the last command."""
    w = robot.w
    x0, y0, yaw0 = current(w)
    twist = {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.4}}
    for _ in range(15):  # a joystick's 10 Hz
        await w.publish("/cmd_vel", twist, "geometry_msgs/Twist")
        await asyncio.sleep(0.1)
    last = current(w)
    await w.until(lambda: still(w), 10, "the robot stopped")
    x, y, yaw = current(w)
    assert math.hypot(last[0] - x0, last[1] - y0) > 0.3
    assert math.remainder(yaw - yaw0, math.tau) > 0.3
    assert math.hypot(x - last[0], y - last[1]) < 0.2

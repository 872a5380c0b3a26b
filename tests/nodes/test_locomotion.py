"""stand_up / sit_down gating every motion path, set_listen, robot_state and the odometry
topics, on a real server with the simulated robot."""

from __future__ import annotations

import math
import time

from hitrobot_server.nodes.locomotion import (
    MAX_VOLTAGE,
    MIN_VOLTAGE,
    pack_current,
    pack_voltage,
    topic_part,
    wheel_speeds,
)
from tests.helpers import Watcher
from tests.nodes.map_manager.util import SPEED

SITTING = "motion refused: the robot is sitting (locomotion state SITDOWN_MODE)"
IN_CONTROL, STANDING_MODE, SITDOWN_MODE = 7, 6, 8
GOAL = "move_base_msgs/MoveBaseActionGoal"


def test_drive_and_battery_model():
    left, right = wheel_speeds(0.4, 0.0)
    assert left == right > 0
    left, right = wheel_speeds(0.0, 1.0)
    assert left == -right < 0
    assert math.isclose(pack_voltage(100, 0.0), MAX_VOLTAGE)
    assert math.isclose(pack_voltage(0, 0.0), MIN_VOLTAGE)
    assert pack_voltage(50, 10.0) < pack_voltage(50, 1.0)  # sag under load
    assert pack_current(0.0, True, False) < pack_current(50.0, True, False)
    assert pack_current(50.0, True, True) < 0  # charging
    assert topic_part("my map 2") == "my_map_2" and topic_part("a/b") == "a_b"


async def start(make_server, tmp_path) -> Watcher:
    server = await make_server(robot="sim", sim_speed=SPEED, map_dir=str(tmp_path / "maps"))
    w = await Watcher.open(server.port)
    await w.client.send({"op": "set_level", "level": "info"})
    await w.subscribe("/robot_state", "hitrobot_msgs/RobotState")
    await w.until(lambda: w.latest("/robot_state"), 10, "robot_state")
    return w


def goal(gid: str, x: float, y: float) -> dict:
    return {"header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0}, "frame_id": ""},
            "goal_id": {"stamp": {"secs": 0, "nsecs": 0}, "id": gid},
            "goal": {"target_pose": {
                "header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0}, "frame_id": "map"},
                "pose": {"position": {"x": x, "y": y, "z": 0.0},
                         "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}}


def result_for(w: Watcher, gid: str) -> dict | None:
    return next((msg["status"] for _t, msg in w.messages.get("/move_base/result", [])
                 if msg["status"]["goal_id"]["id"] == gid), None)


async def test_sit_down_refuses_motion_and_stand_up_allows_it(make_server, tmp_path):
    w = await start(make_server, tmp_path)
    await w.subscribe("/move_base/result")
    assert w.latest("/robot_state")["state"] == IN_CONTROL
    reply = await w.call("/sit_down")
    assert reply["values"] == {"success": True, "message": "Trigger: started"}
    state = await w.next("/robot_state")
    assert state["state"] == SITDOWN_MODE
    assert {a["status"] for a in state["actuator_states"]} == {33}
    # move_base: the goal is ABORTED with the locomotion reason, and the sender is told
    await w.client.send({"op": "advertise", "topic": "/move_base/goal", "type": GOAL})
    await w.publish("/move_base/goal", goal("g1", 6.0, 8.0), op_id="mb1")
    status = await w.until(lambda: result_for(w, "g1"), 10, "the goal's result")
    assert status["status"] == 4 and SITTING in status["text"], status  # ABORTED
    err = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "mb1"), None),
                        5, "a status for the goal")
    assert err["level"] == "error" and SITTING in err["msg"]
    # /cmd_vel and the Slamware node's move_to: a status error to the publisher
    await w.publish("/cmd_vel", {"linear": {"x": 0.3, "y": 0.0, "z": 0.0},
                                 "angular": {"x": 0.0, "y": 0.0, "z": 0.0}},
                    "geometry_msgs/Twist", op_id="vel")
    err = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "vel"), None),
                        5, "a status for cmd_vel")
    assert err["level"] == "error" and SITTING in err["msg"], err
    # the patrol and graph services say so too
    await w.call("/planning/set_waypoints", {"waypoints": [
        {"frame": "map", "x": 6.0, "y": 8.0, "z": 0.0, "use_z": False}]})
    reply = await w.call("/planning/start_patrol")
    assert not reply["values"]["success"] and SITTING in reply["values"]["message"]
    # stand up: STANDING_MODE, then IN_CONTROL, and the same goal now succeeds
    reply = await w.call("/stand_up")
    assert reply["values"] == {"success": True, "message": "Trigger: started"}
    assert (await w.next("/robot_state"))["state"] == STANDING_MODE
    await w.until(lambda: w.latest("/robot_state")["state"] == IN_CONTROL, 5, "IN_CONTROL")
    assert {a["status"] for a in w.latest("/robot_state")["actuator_states"]} == {39}
    await w.publish("/move_base/goal", goal("g2", 6.0, 8.0))
    status = await w.until(lambda: result_for(w, "g2"), 30, "the second goal's result")
    assert status["status"] == 3, status  # SUCCEEDED
    await w.close()


async def test_set_listen_is_reflected_in_robot_state(make_server, tmp_path):
    w = await start(make_server, tmp_path)
    assert w.latest("/robot_state")["joy_listen_type"] == 1  # VEL_CMD: autonomy by default
    for data, kind in [("joy/gui<&>tablet-3", 0), ("joy/gui<&><CLOSE>", 2),
                       ("vel_cmd/autonomy", 1), ("vel_cmd/autonomy<&><CLOSE>", 2)]:
        reply = await w.call("/set_listen", {"data": data})
        assert reply["values"]["success"], reply
        await w.until(lambda k=kind: w.latest("/robot_state")["joy_listen_type"] == k, 5,
                      f"joy_listen_type {kind}")
    reply = await w.call("/set_listen", {"data": "joystick"})
    assert not reply["values"]["success"] and "joy/gui<&>network_id" in reply["values"]["message"]
    await w.close()


async def test_robot_state_fields_rate_and_odometry(make_server, tmp_path):
    w = await start(make_server, tmp_path)
    await w.subscribe("/Odometry", "nav_msgs/Odometry")
    await w.subscribe("/map/robot_0/Odometry", "nav_msgs/Odometry")
    began = time.monotonic()
    count = len(w.messages["/robot_state"])
    await w.until(lambda: time.monotonic() - began > 1.0, 3, "a second")
    rate = (len(w.messages["/robot_state"]) - count) / (time.monotonic() - began)
    assert rate >= 10, rate
    s = w.latest("/robot_state")
    assert [a["name"] for a in s["actuator_states"]] == ["left_wheel", "right_wheel"]
    assert math.hypot(s["base_pos"][0] - 5.0, s["base_pos"][1] - 8.0) < 0.3
    assert len(s["base_quat"]) == 4 and math.isclose(sum(q * q for q in s["base_quat"]), 1.0)
    assert len(s["base_lin_vel"]) == 3 and len(s["base_ang_vel"]) == 3
    assert s["min_voltage"] < s["voltage"] <= s["max_voltage"]
    assert s["current"] > 0 and 0 < s["body_temperature"] < 90
    assert s["state"] == IN_CONTROL
    # driving turns the wheels and draws current
    idle_current = s["current"]
    await w.publish("/cmd_vel", {"linear": {"x": 0.3, "y": 0.0, "z": 0.0},
                                 "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}, "geometry_msgs/Twist")
    moving = await w.until(lambda: (m := w.latest("/robot_state"))["base_lin_vel"][0] > 0.1
                           and m, 5, "the robot moving")
    left, right = moving["actuator_states"]
    assert left["velocity"] > 0 and right["velocity"] > 0 and left["position"] > 0
    assert moving["current"] > idle_current
    # raw and map-frame odometry agree (map→odom is the identity)
    raw, mapped = w.latest("/Odometry"), w.latest("/map/robot_0/Odometry")
    assert raw["header"]["frame_id"].lstrip("/") == "odom"
    assert mapped["header"]["frame_id"].lstrip("/") == "map"
    assert math.isclose(raw["pose"]["pose"]["position"]["x"],
                        mapped["pose"]["pose"]["position"]["x"], abs_tol=0.2)
    # the robot id is a parameter; the topic follows it
    reply = await w.call("/rosapi/set_param", {"name": "/robot_id", "value": '"scout"'})
    assert reply["result"], reply
    await w.subscribe("/map/scout/Odometry", "nav_msgs/Odometry")
    await w.until(lambda: w.latest("/map/scout/Odometry"), 5, "/map/scout/Odometry")
    await w.close()


NS = "/slamware_ros_sdk_server_node"


async def test_set_listen_decides_who_may_drive(start_robot):
    """joy/gui: the joystick's manual commands drive, a goal is refused saying who has
    control; released: nothing drives, /cmd_vel included; vel_cmd/autonomy: goals again."""
    server = await start_robot(sim_speed=SPEED)
    w = await Watcher.open(server.port)
    await w.client.send({"op": "set_level", "level": "info"})
    await w.subscribe(f"{NS}/odom", "nav_msgs/Odometry")
    await w.until(lambda: w.latest(f"{NS}/odom"), 10, "odometry")

    def xy() -> tuple[float, float]:
        p = w.latest(f"{NS}/odom")["pose"]["pose"]["position"]
        return p["x"], p["y"]

    def status(op_id: str):
        return next((s for s in w.statuses if s.get("id") == op_id), None)

    move = {"location": {"x": 7.0, "y": 8.0, "z": 0.0}, "yaw": 0.0,
            "options": {"opt_flags": {"flags": 0}, "speed_ratio": {"is_valid": False,
                                                                   "value": 0.0}}}
    twist = {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
    reply = await w.call("/set_listen", {"data": "joy/gui<&>pad-7"})
    assert reply["values"]["success"], reply
    await w.publish(f"{NS}/move_to", move, "slamware_ros_sdk/MoveToRequest", op_id="goal")
    refused = await w.until(lambda: status("goal"), 10, "the goal refused")
    assert refused["level"] == "error" and "joystick from pad-7 has control" in refused["msg"]
    start = xy()
    for i in range(5):
        await w.publish("/cmd_vel", twist, "geometry_msgs/Twist", op_id=f"joy-{i}")
    await w.until(lambda: math.dist(xy(), start) > 0.05, 10, "the joystick driving")
    assert not any(s["level"] == "error" and s.get("id", "").startswith("joy-")
                   for s in w.statuses)

    reply = await w.call("/set_listen", {"data": "joy/gui<&><CLOSE>"})
    assert reply["values"]["success"], reply
    await w.publish("/cmd_vel", twist, "geometry_msgs/Twist", op_id="nobody")
    refused = await w.until(lambda: status("nobody"), 10, "cmd_vel refused")
    assert refused["level"] == "error" and "no control source" in refused["msg"]

    reply = await w.call("/set_listen", {"data": "vel_cmd/autonomy"})
    assert reply["values"]["success"], reply
    await w.publish(f"{NS}/move_to", move, "slamware_ros_sdk/MoveToRequest", op_id="again")
    done = await w.until(lambda: status("again"), 60, "the goal reached")
    assert done["level"] == "info" and "done" in done["msg"], done
    assert math.dist(xy(), (7.0, 8.0)) < 0.25
    await w.close()

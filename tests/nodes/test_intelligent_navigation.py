"""``/intelligent_navigate_to_pose`` and ``/set_initialpose`` on a real server with the
simulated robot: roslibpy's ROS 2 ``ActionClient`` and raw protocol ops over WebSocket."""

from __future__ import annotations

import asyncio
import math
import threading

import pytest
import roslibpy

from hitrobot_server.nodes.ground.messages import yaw_of
from tests.helpers import Watcher, WsClient
from tests.nodes.robot_setup import RobotSetup

ODOM = "/slamware_ros_sdk_server_node/odom"
ACTION = "/intelligent_navigate_to_pose"
TYPE = "daystar_navigation_msgs/action/IntelligentNavitateToPose"
FAR = (20.0, 8.2)
OFFICE = (10.0, 12.5)
NEAR = (7.0, 8.0)
PLANNING, MOVING, ARRIVED, FAILED, CANCELED = 1, 2, 3, 4, 5


def pose_stamped(x: float, y: float, yaw: float = 0.0, frame: str = "map") -> dict:
    return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": frame},
            "pose": {"position": {"x": x, "y": y, "z": 0.0},
                     "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2),
                                     "w": math.cos(yaw / 2)}}}


def field_list_goal(x: float, y: float, yaw: float = 0.0, **travel) -> dict:
    """The seed's message structure: nav_mode is a NavMode."""
    params = {"speed_mode": {"value": 3}, "gait": {"gait": 2},
              "obstacle_params": {"disable_body_obstacle_avoidance": False},
              "ignore_final_yaw": False, "nav_mode": {"value": 2}, "direction_constraint": 3}
    params.update(travel)
    return {"travel_params": params, "pose": pose_stamped(x, y, yaw), "should_stop": False}


def example_goal(x: float, y: float, **travel) -> dict:
    """The seed's test example: path_following_mode and height, no nav_mode."""
    params = {"speed_mode": {"value": 2}, "gait": {"gait": 5},
              "obstacle_params": {"disable_body_obstacle_avoidance": True},
              "path_following_mode": 4, "direction_constraint": 3, "height": 1}
    params.update(travel)
    return {"travel_params": params, "pose": pose_stamped(x, y)}


ROBOT = RobotSetup(sim_speed=6.0, watch={ODOM: "nav_msgs/Odometry"},
                   ready=lambda w: w.latest(ODOM), ready_what="odometry", client=True)


def pose_of(w: Watcher) -> tuple[float, float, float]:
    p = w.latest(ODOM)["pose"]["pose"]
    return p["position"]["x"], p["position"]["y"], yaw_of(p["orientation"])


def speed(w: Watcher) -> float:
    return abs(w.latest(ODOM)["twist"]["twist"]["linear"]["x"])


async def send(c: WsClient, op_id: str, args: dict, action: str = ACTION) -> None:
    await c.send({"op": "send_action_goal", "id": op_id, "action": action,
                  "action_type": TYPE, "args": args, "feedback": True})


def feedback_of(c: WsClient, op_id: str) -> list[dict]:
    return [m["values"] for m in c.seen if m.get("op") == "action_feedback"
            and m.get("id") == op_id]


async def test_roslibpy_action_client_arrives_with_feedback(robot):
    server, w = robot.server, robot.w
    target = (*OFFICE, math.pi / 2)

    def run() -> tuple[dict, list[dict]]:
        ros = roslibpy.Ros(host="127.0.0.1", port=server.port)
        ros.run(timeout=10)
        try:
            client = roslibpy.ActionClient(ros, ACTION, TYPE)
            feedback: list[dict] = []
            done = threading.Event()
            outcome: dict = {}

            def on_result(result):
                outcome.update(result)
                done.set()

            client.send_goal(roslibpy.Goal(field_list_goal(*target)), on_result,
                             feedback.append, on_result)
            assert done.wait(60), "no result"
            return outcome, feedback
        finally:
            ros.close()

    outcome, feedback = await asyncio.to_thread(run)
    assert outcome["status"] == roslibpy.core.GoalStatus.SUCCEEDED
    assert outcome["values"]["result"] is True and "arrived" in outcome["values"]["message"]
    states = [f["current_state"]["value"] for f in feedback]
    assert MOVING in states and states[-1] == ARRIVED
    last = feedback[-1]["current_pose"]
    assert last["header"]["frame_id"].lstrip("/") == "map"
    x, y, yaw = pose_of(w)
    assert math.hypot(x - OFFICE[0], y - OFFICE[1]) < 0.1
    assert abs(yaw - math.pi / 2) < 0.1  # not ignore_final_yaw: it turned


async def test_example_shape_is_accepted_and_cancel_stops_the_robot(robot):
    w, c = robot.w, robot.c
    # the vendor's test example, path_following_mode 4 (line following) needs virtual tracks;
    # free navigation (2) through the alias drives
    await send(c, "g", example_goal(*FAR, path_following_mode=2),
               action="/nav/intelligent_navigate_to_pose")
    await c.expect(lambda m: m["values"]["current_state"]["value"] == MOVING and speed(w) > 0.1,
                   op="action_feedback", id="g", timeout=15)
    await c.send({"op": "cancel_action_goal", "id": "g",
                  "action": "/nav/intelligent_navigate_to_pose"})
    res = await c.expect(op="action_result", id="g", timeout=10)
    assert res["status"] == 5 and res["values"] == {"message": "canceled", "result": False}
    assert feedback_of(c, "g")[-1]["current_state"]["value"] == CANCELED
    await w.until(lambda: speed(w) < 1e-3, 5, "the robot to stop")
    assert math.hypot(pose_of(w)[0] - FAR[0], pose_of(w)[1] - FAR[1]) > 3.0
    # low speed (2) was applied: never faster than 0.3 of the 0.7 m/s limit
    assert max(abs(t[1]["twist"]["twist"]["linear"]["x"]) for t in w.messages[ODOM]) < 0.22

    # the example as given: line following without virtual tracks fails with the reason
    await send(c, "track", example_goal(*NEAR))
    res = await c.expect(op="action_result", id="track", timeout=10)
    assert res["status"] == 6 and res["values"]["result"] is False
    assert "virtual track" in res["values"]["message"]
    assert feedback_of(c, "track")[-1]["current_state"]["value"] == FAILED


async def test_invalid_travel_params_are_rejected_with_the_reason(robot):
    c = robot.c
    cases = {
        "reverse": (field_list_goal(*NEAR, direction_constraint=4), "reverse"),
        "disagree": (field_list_goal(*NEAR, path_following_mode=3), "disagree"),
        "speed": (field_list_goal(*NEAR, speed_mode={"value": 9}), "speed_mode"),
        "frame": ({**field_list_goal(*NEAR), "pose": pose_stamped(*NEAR, frame="odom")},
                  "map frame"),
    }
    for op_id, (args, words) in cases.items():
        await send(c, op_id, args)
        res = await c.expect(op="action_result", id=op_id, timeout=5)
        assert res["status"] == 6 and res["result"] is False, res
        assert words in res["values"]


async def test_should_stop_cancels_the_running_goal(robot):
    w, c = robot.w, robot.c
    await send(c, "run", field_list_goal(*FAR))
    await c.expect(lambda m: speed(w) > 0.1, op="action_feedback", id="run", timeout=15)
    await send(c, "stop", {"should_stop": True})
    res = await c.expect(op="action_result", id="stop", timeout=5)
    assert res["status"] == 4 and res["values"] == {"message": "stopped", "result": True}
    res = await c.expect(op="action_result", id="run", timeout=5)
    assert res["status"] == 5
    await w.until(lambda: speed(w) < 1e-3, 5, "the robot to stop")
    await send(c, "seed-name", {"should_stop": True}, action="/intelligent_navigat_to_pose")
    res = await c.expect(op="action_result", id="seed-name", timeout=5)
    assert res["status"] == 4 and res["values"]["message"] == "stopped"


async def test_set_initialpose_refines_a_slightly_off_pose(robot):
    w, c = robot.w, robot.c
    true_x, true_y, true_yaw = pose_of(w)
    off = pose_stamped(true_x + 0.25, true_y - 0.15, true_yaw + 0.08)
    reply = await c.call("/set_initialpose", {"init_pose": {
        "header": off["header"], "pose": {"pose": off["pose"], "covariance": [0.0] * 36}}},
        timeout=20)
    assert reply["result"] is True, reply
    values = reply["values"]
    assert values["result"] is True
    refined = values["result_pose"]
    assert refined["header"]["frame_id"].lstrip("/") == "map"
    p = refined["pose"]["pose"]
    assert math.hypot(p["position"]["x"] - true_x, p["position"]["y"] - true_y) < 0.08
    assert abs(yaw_of(p["orientation"]) - true_yaw) < 0.05
    assert len(refined["pose"]["covariance"]) == 36

    bad = await c.call("/set_initialpose", {"init_pose": {"header": {"frame_id": "odom"}}})
    assert bad["result"] is False and "map frame" in bad["values"]


NS = "/slamware_ros_sdk_server_node"
STATE = f"{NS}/robot_basic_state"


def pose_msg(x: float, y: float, yaw: float) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}


def initialpose(x: float, y: float, yaw: float) -> dict:
    off = pose_stamped(x, y, yaw)
    return {"init_pose": {"header": off["header"],
                          "pose": {"pose": off["pose"], "covariance": [0.0] * 36}}}


@pytest.fixture
async def lost_robot(start_robot):
    """A robot (sim or through sim-device) that knows where it truly is: (watcher, true
    pose), localization good to start with."""
    server = await start_robot(sim_speed=4.0)
    w = await Watcher.open(server.port)
    await w.subscribe(ODOM, "nav_msgs/Odometry")
    await w.subscribe(STATE)
    await w.until(lambda: (w.latest(STATE) or {}).get("localization_quality", 0) > 60
                  and w.latest(ODOM), 15, "good localization and odometry")
    truth = pose_of(w)
    yield w, truth
    await w.close()


async def test_set_initialpose_localizes_a_lost_robot_from_an_off_guess(lost_robot):
    """The robot is lost (its pose forced 0.8 m off); a guess 0.6 m / 0.4 rad off the truth
    is refined to the truth, and the reply says so only once quality is good."""
    w, (tx, ty, tyaw) = lost_robot
    await w.publish(f"{NS}/set_pose", pose_msg(tx + 0.8, ty + 0.3, tyaw - 0.3))
    await w.until(lambda: w.latest(STATE)["localization_quality"] < 40, 15, "quality to drop")
    reply = await w.call("/set_initialpose", initialpose(tx + 0.45, ty - 0.4, tyaw + 0.4),
                         timeout=30)
    assert reply["result"] is True and reply["values"]["result"] is True, reply
    p = reply["values"]["result_pose"]["pose"]["pose"]
    assert math.hypot(p["position"]["x"] - tx, p["position"]["y"] - ty) < 0.1
    assert abs(yaw_of(p["orientation"]) - tyaw) < 0.05
    await w.until(lambda: math.hypot(pose_of(w)[0] - tx, pose_of(w)[1] - ty) < 0.1, 5,
                  "odometry at the true pose")
    await w.until(lambda: w.latest(STATE)["localization_quality"] >= 50, 5, "good quality")


async def test_set_initialpose_refuses_a_wrong_guess_and_leaves_the_pose(lost_robot):
    """A guess 3 m away with the heading turned round: result false, pose unchanged."""
    w, (tx, ty, tyaw) = lost_robot
    before = await w.next(ODOM)
    reply = await w.call("/set_initialpose", initialpose(tx + 3.0, ty, tyaw + math.pi),
                         timeout=30)
    assert reply["result"] is True and reply["values"]["result"] is False, reply
    p = reply["values"]["result_pose"]["pose"]["pose"]
    assert math.hypot(p["position"]["x"] - tx, p["position"]["y"] - ty) < 0.05
    after = pose_of(w)
    b = before["pose"]["pose"]["position"]
    assert math.hypot(after[0] - b["x"], after[1] - b["y"]) < 0.05
    assert math.hypot(after[0] - tx, after[1] - ty) < 0.05

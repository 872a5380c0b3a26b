"""``/move_base`` as an actionlib server: roslibpy's real ActionClient against a real server
process with the simulated robot, plus edge cases driven over a raw WebSocket."""

from __future__ import annotations

import asyncio
import math
import threading
import time

import pytest
import roslibpy

try:  # roslibpy 1.x
    from roslibpy.actionlib import ActionClient, Goal, GoalStatus
except ImportError:  # roslibpy 2.x
    from roslibpy.ros1.actionlib import ActionClient, Goal, GoalStatus

from tests.helpers import ServerProcess, Watcher, connect_roslibpy
from tests.nodes.robot_setup import RobotSetup

SPEED = "4"  # simulated seconds per wall second
ACTION = "move_base_msgs/MoveBaseAction"
FAR = (20.0, 8.2)  # the far end of the corridor: a long drive from anywhere else
OFFICE = (10.0, 12.5)


@pytest.fixture(scope="module")
def sim_process():
    proc = ServerProcess("--sim-speed", SPEED, robot="sim")
    yield proc
    proc.stop()


@pytest.fixture
def ros(sim_process):
    r = connect_roslibpy(sim_process.port)
    yield r
    r.close()


def target(x: float, y: float, yaw: float = 0.0, frame: str = "/map") -> roslibpy.Message:
    return roslibpy.Message({"target_pose": {
        "header": {"frame_id": frame},
        "pose": {"position": {"x": x, "y": y, "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2),
                                 "w": math.cos(yaw / 2)}}}})


def wait_for(predicate, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.02)
    return bool(predicate())


def status_of(goal: Goal) -> int:
    return goal.status["status"]


def test_goal_succeeds_with_feedback(ros):
    client = ActionClient(ros, "/move_base", ACTION)  # blocks until a status message arrives
    feedback: list[dict] = []
    goal = Goal(client, target(*OFFICE, yaw=math.pi / 2))
    goal.on("feedback", feedback.append)
    goal.send()
    result = goal.wait(60)
    assert result == {}
    assert status_of(goal) == GoalStatus.SUCCEEDED
    assert feedback, "no feedback while driving"
    last = feedback[-1]["base_position"]
    assert last["header"]["frame_id"].lstrip("/") == "map"
    assert math.hypot(last["pose"]["position"]["x"] - OFFICE[0],
                      last["pose"]["position"]["y"] - OFFICE[1]) < 1.5
    client.dispose()


def test_new_goal_preempts_and_cancel_preempts(ros):
    client = ActionClient(ros, "/move_base", ACTION)
    first = Goal(client, target(*FAR))
    first.send()
    assert wait_for(lambda: status_of(first) == GoalStatus.ACTIVE, 10)
    second = Goal(client, target(*OFFICE))
    second.send()
    first.wait(10)
    assert status_of(first) == GoalStatus.PREEMPTED
    assert "another goal" in first.status["text"]
    assert wait_for(lambda: status_of(second) == GoalStatus.ACTIVE, 10)
    second.cancel()
    second.wait(10)
    assert status_of(second) == GoalStatus.PREEMPTED
    client.dispose()


def test_cancel_all_and_nan_goal_rejected(ros):
    client = ActionClient(ros, "/move_base", ACTION)
    goal = Goal(client, target(*FAR))
    goal.send()
    assert wait_for(lambda: status_of(goal) == GoalStatus.ACTIVE, 10)
    client.cancel()  # an empty GoalID: every goal
    goal.wait(10)
    assert status_of(goal) == GoalStatus.PREEMPTED

    bad = Goal(client, target(float("nan"), 1.0))  # roslibpy sends a NaN literal
    bad.send()
    bad.wait(10)
    assert status_of(bad) == GoalStatus.REJECTED
    assert "finite" in bad.status["text"]
    client.dispose()


def test_status_is_published_at_5_hz_while_idle(ros):
    stamps: list[float] = []
    lock = threading.Lock()

    def on_status(_msg: dict) -> None:
        with lock:
            stamps.append(time.monotonic())

    listener = roslibpy.Topic(ros, "/move_base/status", "actionlib_msgs/GoalStatusArray")
    listener.subscribe(on_status)
    assert wait_for(lambda: stamps, 5)
    time.sleep(2.0)
    listener.unsubscribe()
    with lock:
        first = stamps[0]
        window = [t for t in stamps if t - first <= 2.0]
    assert len(window) >= 10, f"{len(window)} status messages in 2 s"


# ---------------------------------------------------------------- raw WebSocket, in process
ROBOT = RobotSetup(sim_speed=4.0, watch={"/move_base/status": None, "/move_base/result": None},
                   ready=lambda w: w.latest("/move_base/status"), ready_what="a status message",
                   ready_timeout=5)


def goal_msg(goal_id: str, x, y, frame: str = "map", orientation=None) -> dict:
    return {"goal_id": {"id": goal_id},
            "goal": {"target_pose": {"header": {"frame_id": frame}, "pose": {
                "position": {"x": x, "y": y, "z": 0.0},
                "orientation": orientation or {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}}}


async def result_for(w: Watcher, goal_id: str, timeout: float = 30) -> dict:
    def find():
        return next((msg["status"] for _t, msg in w.messages.get("/move_base/result", [])
                     if msg["status"]["goal_id"]["id"] == goal_id), None)
    return await w.until(find, timeout, f"the result of {goal_id}")


async def test_unreachable_goal_is_aborted_with_the_robots_reason(robot):
    w = robot.w
    await w.publish("/move_base/goal", goal_msg("nowhere", 100.0, 100.0),
                    "move_base_msgs/MoveBaseActionGoal", op_id="g")
    status = await result_for(w, "nowhere")
    assert status["status"] == 4 and status["text"]  # ABORTED, with the robot's reason
    err = await w.until(lambda: [s for s in w.statuses if s.get("id") == "g"], 5, "a status")
    assert "aborted" in err[0]["msg"]
    # the finished goal stays listed in the status array for a while
    await w.next("/move_base/status")
    listed = {s["goal_id"]["id"]: s["status"] for s in w.latest("/move_base/status")["status_list"]}
    assert listed.get("nowhere") == 4


async def test_invalid_goals_are_rejected_and_keep_the_running_goal(robot):
    w = robot.w
    await w.publish("/move_base/goal", goal_msg("run", *FAR), "move_base_msgs/MoveBaseActionGoal")
    await w.until(lambda: any(s["goal_id"]["id"] == "run" and s["status"] == 1
                              for s in w.latest("/move_base/status")["status_list"]), 5, "ACTIVE")
    await w.publish("/move_base/goal", goal_msg("odom", 6.0, 8.0, frame="odom"))
    await w.publish("/move_base/goal", goal_msg("nan", None, 8.0))  # null = NaN
    assert (await result_for(w, "odom"))["status"] == 5
    nan = await result_for(w, "nan")
    assert nan["status"] == 5 and "goal.target_pose.pose.position" in nan["text"]
    listed = {s["goal_id"]["id"]: s["status"] for s in w.latest("/move_base/status")["status_list"]}
    assert listed["run"] == 1  # still running
    # a goal without orientation (nav2d withOrientation: false) is fine: yaw 0
    zero = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}
    await w.publish("/move_base/goal", goal_msg("", 6.0, 8.0, orientation=zero))
    assert (await result_for(w, "run"))["status"] == 2  # PREEMPTED by the new goal
    await w.until(lambda: any(s["status"] == 3 for s in
                              w.latest("/move_base/status")["status_list"]
                              if s["goal_id"]["id"].startswith("/move_base-")), 30,
                  "the generated-id goal SUCCEEDED")


async def test_cancel_before_the_robot_started_recalls(robot):
    server, w = robot.server, robot.w
    caps = server.robot
    real_move_to = caps.motion.move_to

    asked, moved = asyncio.Event(), asyncio.Event()

    async def slow_move_to(*args, **kw):
        asked.set()
        await asyncio.sleep(0.5)  # a slow robot link
        try:
            return await real_move_to(*args, **kw)
        finally:
            moved.set()

    caps.motion.move_to = slow_move_to
    await w.publish("/move_base/goal", goal_msg("slow", *FAR), "move_base_msgs/MoveBaseActionGoal")
    await asyncio.wait_for(asked.wait(), 5)  # the goal is on its way to the robot
    await w.publish("/move_base/cancel", {"id": "slow"}, "actionlib_msgs/GoalID")
    assert (await result_for(w, "slow"))["status"] == 8  # RECALLED
    await asyncio.wait_for(moved.wait(), 5)  # the robot was told to move meanwhile
    deadline = time.monotonic() + 5  # ... so it must be stopped again
    while (action := await caps.motion.get_current_action()) is not None:
        assert time.monotonic() < deadline, f"the late move was not stopped: {action}"
        await asyncio.sleep(0.02)

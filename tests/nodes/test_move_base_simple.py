"""``/move_base_simple/goal`` as in ROS: move_base wraps the PoseStamped as an action goal
(its id generated), lists it on ``/move_base/status``, sends feedback and ends it with a
``/move_base/result``; a new simple goal preempts the running one. The Slamware node, beside
move_base in every assembly, leaves the topic alone."""

from __future__ import annotations

import math

from hitrobot_server.bus.core import Bus
from hitrobot_server.nodes.move_base import (
    ABORTED,
    ACTIVE,
    NEW_GOAL_TEXT,
    PREEMPTED,
    REJECTED,
    SUCCEEDED,
)
from hitrobot_server.nodes.slamware import SlamwareNode
from hitrobot_server.nodes.slamware.topics import NODE_NAME
from hitrobot_server.robot.factory import build_simulator, robot_of
from hitrobot_server.robot.sim.backend import SimBackend
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import Watcher
from tests.nodes.robot_setup import RobotSetup

SIMPLE = "/move_base_simple/goal"
STATUS, FEEDBACK, RESULT = "/move_base/status", "/move_base/feedback", "/move_base/result"
NEAR = (7.0, 8.0)  # two metres along the corridor from the start (5, 8)
FAR = (20.0, 8.2)  # the far end of the corridor: a long drive

ROBOT = RobotSetup(sim_speed=4.0, watch={STATUS: None, FEEDBACK: None, RESULT: None,
                                         "/robot_pose": None},
                   ready=lambda w: w.latest(STATUS) and w.latest("/robot_pose"),
                   ready_what="a status message and the robot's pose", ready_timeout=5)


def pose_stamped(x, y, frame: str = "map") -> dict:
    return {"header": {"frame_id": frame},
            "pose": {"position": {"x": x, "y": y, "z": 0.0},
                     "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}


def listed(w: Watcher) -> dict[str, int]:
    """Goal id → status in the latest status list."""
    return {s["goal_id"]["id"]: s["status"] for s in (w.latest(STATUS) or {"status_list": []})
            ["status_list"]}


async def new_goal(w: Watcher, known: set[str], timeout: float = 5) -> str:
    """The id of the first goal listed ACTIVE that is not in ``known``."""
    return await w.until(lambda: next((gid for gid, status in listed(w).items()
                                       if gid not in known and status == ACTIVE), None),
                         timeout, "a new ACTIVE goal on /move_base/status")


async def result_for(w: Watcher, goal_id: str, timeout: float = 30) -> dict:
    def find():
        return next((msg["status"] for _t, msg in w.messages.get(RESULT, [])
                     if msg["status"]["goal_id"]["id"] == goal_id), None)
    return await w.until(find, timeout, f"the result of {goal_id}")


def feedback_for(w: Watcher, goal_id: str) -> list[dict]:
    return [msg for _t, msg in w.messages.get(FEEDBACK, [])
            if msg["status"]["goal_id"]["id"] == goal_id]


async def test_only_move_base_takes_simple_goals(robot):
    topic = robot.server.bus.topic(SIMPLE)
    assert topic is not None
    owners = {node for node, _callback in topic.subscribers.values()}
    assert "/move_base" in owners and NODE_NAME not in owners


async def test_a_slamware_node_alone_still_drives_simple_goals():
    """Without a move_base beside it (not an assembly of ours) the node keeps its own."""
    for own, subscribed in ((True, True), (False, False)):
        bus = Bus(TypeRegistry.default(), unregister_timeout=0)
        node = SlamwareNode(bus, robot_of(SimBackend(build_simulator())), simple_goals=own)
        topic = bus.topic(SIMPLE)
        owners = {name for name, _callback in topic.subscribers.values()} if topic else set()
        assert (NODE_NAME in owners) is subscribed
        node.close()


async def test_simple_goal_is_listed_gets_feedback_and_succeeds(robot):
    w = robot.w
    await w.publish(SIMPLE, pose_stamped(*NEAR), "geometry_msgs/PoseStamped", op_id="simple")
    gid = await new_goal(w, set())
    assert gid.startswith("/move_base-")  # generated as actionlib's GoalIDGenerator does
    await w.until(lambda: feedback_for(w, gid), 10, "feedback for the simple goal")
    status = await result_for(w, gid)
    assert status["status"] == SUCCEEDED
    last = feedback_for(w, gid)[-1]["feedback"]["base_position"]["pose"]["position"]
    assert math.hypot(last["x"] - NEAR[0], last["y"] - NEAR[1]) < 1.5
    pose = w.latest("/robot_pose")["position"]
    assert math.hypot(pose["x"] - NEAR[0], pose["y"] - NEAR[1]) < 0.25  # it arrived
    # the finished goal stays listed, and the publisher heard no error
    await w.next(STATUS)
    assert listed(w).get(gid) == SUCCEEDED
    assert not [s for s in w.statuses if s.get("id") == "simple" and s["level"] == "error"]


async def test_a_new_simple_goal_preempts_the_running_one(robot):
    w = robot.w
    await w.publish(SIMPLE, pose_stamped(*FAR), "geometry_msgs/PoseStamped")
    first = await new_goal(w, set())
    await w.until(lambda: feedback_for(w, first), 10, "feedback for the first goal")
    await w.publish(SIMPLE, pose_stamped(*NEAR))
    ended = await result_for(w, first, 10)
    assert ended["status"] == PREEMPTED and ended["text"] == NEW_GOAL_TEXT
    second = await new_goal(w, {first})
    assert (await result_for(w, second))["status"] == SUCCEEDED
    pose = w.latest("/robot_pose")["position"]
    assert math.hypot(pose["x"] - NEAR[0], pose["y"] - NEAR[1]) < 0.25


async def test_simple_and_action_goals_preempt_each_other(robot):
    w = robot.w
    await w.publish("/move_base/goal", {"goal_id": {"id": "action"},
                                        "goal": {"target_pose": pose_stamped(*FAR)}},
                    "move_base_msgs/MoveBaseActionGoal")
    await w.until(lambda: listed(w).get("action") == ACTIVE, 5, "the action goal ACTIVE")
    await w.publish(SIMPLE, pose_stamped(*FAR), "geometry_msgs/PoseStamped")
    assert (await result_for(w, "action", 10))["status"] == PREEMPTED
    simple = await new_goal(w, {"action"})
    await w.publish("/move_base/goal", {"goal_id": {"id": "again"},
                                        "goal": {"target_pose": pose_stamped(*NEAR)}})
    assert (await result_for(w, simple, 10))["status"] == PREEMPTED
    assert (await result_for(w, "again"))["status"] == SUCCEEDED


async def test_bad_simple_goals_are_rejected_with_their_field(robot):
    w = robot.w
    await w.publish(SIMPLE, pose_stamped(6.0, 8.0, frame="odom"), "geometry_msgs/PoseStamped",
                    op_id="odom")
    err = await w.until(lambda: [s for s in w.statuses if s.get("id") == "odom"], 5,
                        "the publisher told")
    assert err[0]["level"] == "error"
    assert "rejected: field 'header.frame_id': 'odom' is not the map frame" in err[0]["msg"]
    rejected = [msg["status"] for _t, msg in w.messages.get(RESULT, [])]
    assert rejected[-1]["status"] == REJECTED
    await w.publish(SIMPLE, pose_stamped(None, 8.0), op_id="nan")  # null = NaN
    err = await w.until(lambda: [s for s in w.statuses if s.get("id") == "nan"], 5,
                        "the publisher told")
    assert "field 'pose.position'" in err[0]["msg"]
    # an unreachable simple goal ends ABORTED with the robot's reason
    await w.publish(SIMPLE, pose_stamped(100.0, 100.0))
    aborted = await w.until(lambda: [msg["status"] for _t, msg in w.messages.get(RESULT, [])
                                     if msg["status"]["status"] == ABORTED], 30, "an ABORTED")
    assert aborted[0]["text"]

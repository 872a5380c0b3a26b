"""``/robot_pose`` and ``/initialpose`` (seed §4.3) against a real server with the simulator."""

from __future__ import annotations

import asyncio
import math
import time

import pytest

from hitrobot_server.nodes.ground.messages import yaw_of
from tests.nodes.robot_setup import RobotSetup

POSE_TYPE = "geometry_msgs/PoseWithCovarianceStamped"


ROBOT = RobotSetup(sim_speed=4.0, watch={"/robot_pose": "geometry_msgs/Pose"},
                   ready=lambda w: w.latest("/robot_pose"), ready_what="a robot pose",
                   ready_timeout=5)


def estimate(x, y, yaw: float = 0.0, frame: str = "/map") -> dict:
    return {"header": {"frame_id": frame}, "pose": {"pose": {
        "position": {"x": x, "y": y, "z": 0.0},
        "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}}}


def planar(pose: dict) -> tuple[float, float, float]:
    return pose["position"]["x"], pose["position"]["y"], yaw_of(pose["orientation"])


async def test_robot_pose_is_published_at_10_hz_or_more(robot):
    w = robot.w
    count = len(w.messages["/robot_pose"])
    began = time.monotonic()
    await asyncio.sleep(1.0)
    rate = (len(w.messages["/robot_pose"]) - count) / (time.monotonic() - began)
    assert rate >= 10.0, f"{rate:.1f} Hz"
    x, y, _yaw = planar(w.latest("/robot_pose"))
    assert math.hypot(x - 5.0, y - 8.0) < 0.2  # the office world's start pose


async def test_initialpose_moves_the_believed_pose(robot):
    w = robot.w
    await w.publish("/initialpose", estimate(5.4, 8.2, 0.7), POSE_TYPE, op_id="ip")

    def moved():
        x, y, yaw = planar(w.latest("/robot_pose"))
        return math.hypot(x - 5.4, y - 8.2) < 0.05 and abs(yaw - 0.7) < 0.05

    await w.until(moved, 5, "the new believed pose on /robot_pose")
    assert not [s for s in w.statuses if s.get("id") == "ip"]


@pytest.mark.parametrize("bad, words", [
    (estimate(None, 8.0), "finite"),  # null = NaN
    ({**estimate(5.0, 8.0), "header": {"frame_id": "base_link"}}, "map frame"),
])
async def test_invalid_initialpose_is_refused(robot, bad, words):
    w = robot.w
    before = planar(w.latest("/robot_pose"))
    await w.publish("/initialpose", bad, POSE_TYPE, op_id="bad")
    status = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "bad"), None),
                           5, "a status error")
    assert status["level"] == "error" and words in status["msg"]
    for _ in range(2):  # poses the robot reported after the refusal, not just a wall-clock gap
        after = planar(await w.next("/robot_pose", 5))
    assert math.hypot(after[0] - before[0], after[1] - before[1]) < 0.05

"""``/compute_path_to_pose`` and ``/follow_path`` (nav2_msgs actions) on a real server with the
simulated robot, through the protocol's ``send_action_goal`` / ``cancel_action_goal`` ops."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitrobot_server.nodes.ground.messages import yaw_of
from hitrobot_server.nodes.nav2_actions import PathProgress, resample, simplify
from hitrobot_server.robot.model import Point2D
from hitrobot_server.robot.sim.world import load_world
from tests.helpers import Watcher, WsClient
from tests.nodes.robot_setup import RobotSetup

ODOM = "/slamware_ros_sdk_server_node/odom"
COMPUTE = "/compute_path_to_pose"
FOLLOW = "/follow_path"
FAR = (20.0, 8.2)      # the far end of the corridor
OFFICE = (10.0, 12.5)  # through a door from the start (5, 8)


def pose_stamped(x: float, y: float, yaw: float = 0.0, frame: str = "map") -> dict:
    return {"header": {"frame_id": frame},
            "pose": {"position": {"x": x, "y": y, "z": 0.0},
                     "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2),
                                     "w": math.cos(yaw / 2)}}}


def xy(stamped: dict) -> tuple[float, float]:
    p = stamped["pose"]["position"]
    return p["x"], p["y"]


@pytest.fixture(scope="module")
def world():
    return load_world()


def solid_at(world, x: float, y: float) -> bool:
    s = world.spec
    return bool(world.solid[int((y - s.origin_y) / s.resolution),
                            int((x - s.origin_x) / s.resolution)])


ROBOT = RobotSetup(sim_speed=6.0, watch={ODOM: "nav_msgs/Odometry"},
                   ready=lambda w: w.latest(ODOM), ready_what="odometry", client=True)


def robot_xy(w: Watcher) -> tuple[float, float]:
    p = w.latest(ODOM)["pose"]["pose"]["position"]
    return p["x"], p["y"]


def speed(w: Watcher) -> float:
    return abs(w.latest(ODOM)["twist"]["twist"]["linear"]["x"])


async def compute(c: WsClient, goal: dict, op_id: str = "plan", **extra) -> dict:
    await c.send({"op": "send_action_goal", "id": op_id, "action": COMPUTE,
                  "action_type": "nav2_msgs/action/ComputePathToPose",
                  "args": {"goal": goal, **extra}})
    return await c.expect(op="action_result", id=op_id, timeout=20)


# ------------------------------------------------------------------ pure helpers
def test_path_helpers():
    pts = np.array([[0.0, 0.0], [1.0, 0.01], [2.0, 0.0], [2.0, 1.0]])
    assert simplify(pts, 0.05).tolist() == [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]]
    dense = resample([Point2D(0, 0), Point2D(1, 0)], 0.3)
    assert len(dense) == 5 and dense[-1] == Point2D(1, 0)
    progress = PathProgress(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]]))
    assert progress.remaining(0.0, 0.0) == pytest.approx(4.0)
    assert progress.remaining(1.5, 0.2) == pytest.approx(2.5)
    assert progress.remaining(0.0, 0.0) == pytest.approx(2.5)  # never goes back
    assert progress.remaining(2.1, 1.0) == pytest.approx(1.0)


# ------------------------------------------------------------------ over the wire
async def test_compute_path_is_collision_free_and_ends_at_the_goal(robot, world):
    w, c = robot.w, robot.c
    res = await compute(c, pose_stamped(*FAR, yaw=math.pi / 2))
    assert res["status"] == 4 and res["result"] is True
    path = res["values"]["path"]
    poses = path["poses"]
    assert path["header"]["frame_id"].lstrip("/") == "map" and len(poses) > 50
    sx, sy = robot_xy(w)
    assert math.dist(xy(poses[0]), (sx, sy)) < 0.3
    assert math.dist(xy(poses[-1]), FAR) < 0.05
    assert yaw_of(poses[-1]["pose"]["orientation"]) == pytest.approx(math.pi / 2)
    for a, b in zip(poses, poses[1:], strict=False):
        (x0, y0), (x1, y1) = xy(a), xy(b)
        assert math.hypot(x1 - x0, y1 - y0) <= 0.0501
        for t in np.linspace(0.0, 1.0, 5):
            assert not solid_at(world, x0 + t * (x1 - x0), y0 + t * (y1 - y0))
    planning = res["values"]["planning_time"]
    assert planning["sec"] >= 0 and 0 <= planning["nanosec"] < 10**9  # ROS 2 (issue 49)

    # use_start plans from the given start, not from the robot
    res = await compute(c, pose_stamped(*OFFICE), "from", start=pose_stamped(15.0, 8.0),
                        use_start=True)
    assert res["status"] == 4
    assert math.dist(xy(res["values"]["path"]["poses"][0]), (15.0, 8.0)) < 0.05

    # no path, and a goal in another frame: aborted with the reason
    res = await compute(c, pose_stamped(-40.0, -40.0), "nowhere")
    assert res["status"] == 6 and res["result"] is False and "no free space" in res["values"]
    res = await compute(c, pose_stamped(*FAR, frame="odom"), "frame")
    assert res["status"] == 6 and "map frame" in res["values"]


async def test_follow_path_drives_it_with_decreasing_distance(robot):
    w, c = robot.w, robot.c
    plan = await compute(c, pose_stamped(*OFFICE, yaw=math.pi / 2))
    path = plan["values"]["path"]
    await c.send({"op": "send_action_goal", "id": "follow", "action": FOLLOW,
                  "action_type": "nav2_msgs/action/FollowPath",
                  "args": {"path": path, "controller_id": "FollowPath"}, "feedback": True})
    res = await c.expect(op="action_result", id="follow", timeout=60)
    assert res["status"] == 4 and res["result"] is True, res
    feedback = [m["values"] for m in c.seen if m.get("op") == "action_feedback"
                and m.get("id") == "follow"]
    assert len(feedback) > 10
    distances = [f["distance_to_goal"] for f in feedback]
    assert all(b <= a + 1e-6 for a, b in zip(distances, distances[1:], strict=False))
    assert distances[0] > 3.0 and distances[-1] < 0.3
    assert max(f["speed"] for f in feedback) > 0.2
    await w.until(lambda: math.dist(robot_xy(w), OFFICE) < 0.3, 5, "the robot at the end")


async def test_follow_path_cancel_stops_the_robot(robot):
    w, c = robot.w, robot.c
    plan = await compute(c, pose_stamped(*FAR))
    await c.send({"op": "send_action_goal", "id": "far", "action": FOLLOW,
                  "action_type": "nav2_msgs/action/FollowPath",
                  "args": {"path": plan["values"]["path"]}, "feedback": True})
    await c.expect(lambda m: m["values"]["speed"] > 0.1, op="action_feedback", id="far",
                   timeout=15)
    await c.send({"op": "cancel_action_goal", "id": "far", "action": FOLLOW})
    res = await c.expect(op="action_result", id="far", timeout=10)
    assert res["status"] == 5
    await w.until(lambda: speed(w) < 1e-3, 5, "the robot to stop")
    assert math.dist(robot_xy(w), FAR) > 3.0

    empty = {"header": {"frame_id": "map"}, "poses": []}
    await c.send({"op": "send_action_goal", "id": "empty", "action": FOLLOW,
                  "action_type": "nav2_msgs/action/FollowPath", "args": {"path": empty}})
    res = await c.expect(op="action_result", id="empty", timeout=5)
    assert res["status"] == 6 and "empty" in res["values"]

"""One simulated world for several robots: start spots, lidar, collisions and planning."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitrobot_server.robot.factory import shared_world
from hitrobot_server.robot.model import ActionStatus, Point2D, Pose2D
from hitrobot_server.robot.options import RobotOptions

TICK = 0.025
CORRIDOR_Y = 8.0  # the office's east-west corridor (free from x ≈ 0.5 to 22 at y 7.5-8.5)


def gap(a, b) -> float:
    return math.hypot(a.true_pose.x - b.true_pose.x, a.true_pose.y - b.true_pose.y)


@pytest.fixture(scope="module")
def world():
    return shared_world(RobotOptions())


def fresh(world_template):
    """A new shared world on the same (immutable) office world."""
    from hitrobot_server.robot.sim.shared import SharedWorld
    return SharedWorld(world_template.world, world_template.config)


def test_each_robot_starts_at_its_own_free_spot(world):
    w = fresh(world)
    robots = [w.add(i, None, 1.0).simulator for i in range(3)]
    assert robots[0].true_pose == pytest.approx(robots[0].start)
    for i, a in enumerate(robots):
        for b in robots[i + 1:]:
            assert gap(a, b) >= 1.0 - 1e-9
        assert a.costmap().lethal_at(np.array([[a.true_pose.x, a.true_pose.y]])).tolist() == [
            False]  # its own disc is no obstacle to itself


def test_a_given_start_is_checked(world):
    w = fresh(world)
    w.add(0, Pose2D(6.0, CORRIDOR_Y, 0.0), 1.0)
    with pytest.raises(ValueError, match="on another robot"):
        w.add(1, Pose2D(6.2, CORRIDOR_Y, 0.0), 1.0)
    with pytest.raises(ValueError, match="not a free spot"):
        w.add(1, Pose2D(-0.4, -0.4, 0.0), 1.0)  # in the outer wall
    assert len(w.robots) == 1  # a refused robot never joined


def test_the_lidar_sees_the_other_robot(world):
    w = fresh(world)
    a = w.add(0, Pose2D(5.0, CORRIDOR_Y, 0.0), 1.0).simulator
    w.add(1, Pose2D(8.0, CORRIDOR_Y, 0.0), 1.0)
    a.step(0.2)  # a scan after the other robot joined
    scan = a.latest_scan
    ahead = int(np.argmin(np.abs(scan.angles)))
    assert scan.ranges[ahead] == pytest.approx(3.0 - 0.2, abs=0.05)  # its disc's near edge


def test_robots_never_drive_through_each_other(world):
    w = fresh(world)
    a = w.add(0, Pose2D(5.0, CORRIDOR_Y, 0.0), 1.0).simulator
    b = w.add(1, Pose2D(6.5, CORRIDOR_Y, math.pi), 1.0).simulator
    closest = gap(a, b)
    for _ in range(int(6 / TICK)):  # both drive straight at each other, blind to the planner
        a.actions.set_velocity(0.5, 0.0)
        b.actions.set_velocity(0.5, 0.0)
        a.step(TICK)
        b.step(TICK)
        closest = min(closest, gap(a, b))
    assert closest >= 2 * a.drive.radius - 1e-6
    assert closest < 0.5  # they did meet: the bumpers stopped them, not a wall


def test_the_planner_drives_around_a_robot_in_the_corridor(world):
    w = fresh(world)
    a = w.add(0, Pose2D(5.0, CORRIDOR_Y, 0.0), 1.0).simulator
    parked = w.add(1, Pose2D(8.0, CORRIDOR_Y, 0.0), 1.0).simulator
    a.actions.move_to([Point2D(11.0, CORRIDOR_Y)])
    closest = gap(a, parked)
    for _ in range(int(60 / TICK)):
        a.step(TICK)
        closest = min(closest, gap(a, parked))
        if a.actions.current_action() is None:
            break
    assert a.actions.action(1).status == ActionStatus.DONE and not a.actions.action(1).reason
    assert math.hypot(a.true_pose.x - 11.0, a.true_pose.y - CORRIDOR_Y) < 0.3
    assert closest > 2 * a.drive.radius + 0.05  # passed it with room, never touched it


def test_two_robots_pass_each_other_in_the_corridor(world):
    w = fresh(world)
    a = w.add(0, Pose2D(4.0, CORRIDOR_Y, 0.0), 1.0).simulator
    b = w.add(1, Pose2D(12.0, CORRIDOR_Y, math.pi), 1.0).simulator
    a.actions.move_to([Point2D(12.0, CORRIDOR_Y)])
    b.actions.move_to([Point2D(4.0, CORRIDOR_Y)])
    closest = gap(a, b)
    for _ in range(int(90 / TICK)):
        a.step(TICK)
        b.step(TICK)
        closest = min(closest, gap(a, b))
        if a.actions.current_action() is None and b.actions.current_action() is None:
            break
    assert closest >= 2 * a.drive.radius - 1e-6
    assert math.hypot(a.true_pose.x - 12.0, a.true_pose.y - CORRIDOR_Y) < 0.3
    assert math.hypot(b.true_pose.x - 4.0, b.true_pose.y - CORRIDOR_Y) < 0.3


def test_a_reboot_keeps_the_start_and_the_neighbours(world):
    w = fresh(world)
    robot = w.add(0, Pose2D(5.0, CORRIDOR_Y, 0.0), 1.0)
    w.add(1, Pose2D(8.0, CORRIDOR_Y, 0.0), 1.0)
    robot.runner.simulator = robot.simulator.restarted()  # what SimRunner.reboot does
    assert robot.simulator.start == Pose2D(5.0, CORRIDOR_Y, 0.0)
    assert robot.simulator.others() == [Pose2D(8.0, CORRIDOR_Y, 0.0)]

import math

import pytest

from hitrobot_server.robot.model import Pose2D
from hitrobot_server.robot.planning.geometry import wrap_angle
from hitrobot_server.robot.planning.search import PRECISE_TOLERANCE
from hitrobot_server.robot.sim.follower import PathFollower
from hitrobot_server.robot.sim.kinematics import DiffDrive, DriveLimits

DT = 0.025


def _drive(follower: PathFollower, start: Pose2D, seconds: float = 60.0) -> DiffDrive:
    drive = DiffDrive(start, DriveLimits(), lambda x, y: math.inf)
    for _ in range(round(seconds / DT)):
        linear, angular = follower.command(drive.pose)
        drive.step(linear, angular, DT)
        if follower.done:
            break
    return drive


def test_follows_an_l_shaped_path_precisely_and_turns():
    path = [(0.0, 0.0), (3.0, 0.0), (3.0, 2.0)]
    follower = PathFollower(path, DriveLimits(), tolerance=PRECISE_TOLERANCE, final_yaw=math.pi)
    drive = _drive(follower, Pose2D(0.0, 0.0, 0.0))
    assert follower.done
    assert math.hypot(drive.pose.x - 3.0, drive.pose.y - 2.0) < 0.05
    assert abs(wrap_angle(drive.pose.yaw - math.pi)) < 0.05


def test_turns_in_place_when_the_path_starts_behind():
    follower = PathFollower([(0.0, 0.0), (-2.0, 0.0)], DriveLimits())
    linear, angular = follower.command(Pose2D(0.0, 0.0, 0.0))
    assert linear == 0.0 and angular != 0.0
    drive = _drive(follower, Pose2D(0.0, 0.0, 0.0))
    assert follower.done and drive.pose.x == pytest.approx(-2.0, abs=0.15)


def test_speed_ratio_caps_speed():
    follower = PathFollower([(0.0, 0.0), (10.0, 0.0)], DriveLimits(), speed_ratio=0.3)
    drive = DiffDrive(Pose2D(0.0, 0.0, 0.0), DriveLimits(), lambda x, y: math.inf)
    top = 0.0
    for _ in range(400):
        drive.step(*follower.command(drive.pose), DT)
        top = max(top, drive.linear)
    assert top == pytest.approx(0.3 * DriveLimits().max_linear)


def test_remaining_path_starts_at_the_robot():
    follower = PathFollower([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], DriveLimits())
    follower.command(Pose2D(0.5, 0.0, 0.0))
    assert follower.remaining_path(Pose2D(0.5, 0.0, 0.0)) == [(0.5, 0.0), (1.0, 0.0), (1.0, 1.0)]

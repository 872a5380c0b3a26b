import math

import pytest

from hitrobot_server.robot.model import Pose2D
from hitrobot_server.robot.sim.kinematics import DiffDrive, DriveLimits

DT = 0.025


def _open(x: float, y: float) -> float:
    return math.inf


def _wall_at_x2(x: float, y: float) -> float:
    return 2.0 - x


def test_acceleration_and_speed_limits():
    limits = DriveLimits()
    drive = DiffDrive(Pose2D(0.0, 0.0, 0.0), limits, _open)
    drive.step(10.0, 10.0, DT)
    assert drive.linear == pytest.approx(limits.linear_accel * DT)
    assert drive.angular == pytest.approx(limits.angular_accel * DT)
    for _ in range(200):
        drive.step(10.0, 0.0, DT)
    assert drive.linear == pytest.approx(limits.max_linear)
    assert drive.angular == pytest.approx(0.0)


def test_straight_line_and_arc_integration():
    drive = DiffDrive(
        Pose2D(0.0, 0.0, 0.0), DriveLimits(linear_accel=1e9, angular_accel=1e9), _open
    )
    for _ in range(40):
        drive.step(0.5, 0.0, DT)
    assert drive.pose.x == pytest.approx(0.5) and drive.pose.y == pytest.approx(0.0)
    for _ in range(100):
        drive.step(0.5, 1.0, math.pi / 100)  # half a circle of radius 0.5
    assert drive.pose.x == pytest.approx(0.5, abs=1e-9)
    assert drive.pose.y == pytest.approx(1.0, abs=1e-9)
    assert drive.pose.yaw == pytest.approx(-math.pi, abs=1e-9) or drive.pose.yaw == pytest.approx(
        math.pi, abs=1e-9
    )


def test_collision_stops_and_reports_a_front_contact():
    drive = DiffDrive(Pose2D(1.0, 0.0, 0.0), DriveLimits(), _wall_at_x2)
    contacts = []
    for _ in range(200):
        contact = drive.step(0.5, 0.0, DT)
        if contact is not None:
            contacts.append(contact)
    assert contacts and abs(contacts[0]) < math.radians(15)
    assert drive.pose.x <= 2.0 - drive.limits.radius
    assert drive.linear == 0.0
    # Backing away is always allowed.
    for _ in range(20):
        assert drive.step(-0.3, 0.0, DT) is None
    assert drive.pose.x < 1.7

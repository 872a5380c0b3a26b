"""Pure conversions of the Slamware node: laser compensation, occupancy mapping, quaternions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitrobot_server.nodes.ground import messages as m
from hitrobot_server.robot.model import (
    BasicSensorInfo,
    BasicSensorValue,
    ImpactType,
    LaserScan,
    Pose2D,
    SensorType,
)


def scan(angles, ranges) -> LaserScan:
    return LaserScan(Pose2D(1.0, 2.0, 0.5), np.asarray(angles, float), np.asarray(ranges, float),
                     100.0)


def test_compensated_scan_has_360_bins_from_minus_pi_and_closest_angle_wins():
    inc = 2 * math.pi / 360
    # two points fall into bin 180 (angle 0): the one nearer the bin centre must win
    msg = m.laser_scan(scan([0.004, -0.0001, 1.0, math.pi - 0.001], [5.0, 3.0, 2.0, 7.0]),
                       "/laser", True, 0.1, 1.8e9 + 0.25)
    assert msg["header"]["stamp"] == {"secs": 1_800_000_000, "nsecs": 250_000_000}
    assert len(msg["ranges"]) == 360
    assert msg["angle_min"] == pytest.approx(-math.pi)
    assert msg["angle_max"] == pytest.approx(math.pi - inc)
    assert msg["ranges"][180] == 3.0
    assert msg["ranges"][180 + round(1.0 / inc)] == 2.0
    assert msg["ranges"][0] == 7.0  # +pi wraps to the first bin (-pi)
    assert np.isinf(msg["ranges"][90])  # empty bins are +inf
    assert msg["range_min"] == 2.0 and msg["range_max"] == 7.0
    assert msg["time_increment"] == pytest.approx(0.1 / 359)


def test_descending_source_angles_reverse_the_compensated_scan():
    msg = m.laser_scan(scan([1.0, 0.0, -1.0], [1.0, 2.0, 3.0]), "/laser", True, 0.1, 0.0)
    assert msg["angle_min"] == pytest.approx(math.pi)
    assert msg["angle_increment"] < 0
    assert msg["ranges"][180] == 2.0  # angle 0 is still the middle bin


def test_uncompensated_scan_keeps_points_and_marks_invalid_as_inf():
    msg = m.laser_scan(scan([-0.5, 0.0, 0.5], [1.0, math.inf, 3.0]), "/laser", False, 0.2, 0.0)
    assert list(msg["ranges"][[0, 2]]) == [1.0, 3.0] and np.isinf(msg["ranges"][1])
    assert msg["angle_min"] == -0.5 and msg["angle_increment"] == pytest.approx(0.5)


def test_fewer_than_two_returns_publish_nothing():
    assert m.laser_scan(scan([0.0, 0.1], [1.0, math.inf]), "/laser", True, 0.1, 0.0) is None


def test_occupancy_lut_and_quaternions():
    cells = np.array([0, 1, 127, 128, 255], dtype=np.uint8)
    assert m.OCCUPANCY_LUT[cells].tolist() == [-1, 0, 0, 100, 100]
    for yaw in (-3.0, -0.5, 0.0, 1.0, 3.1):
        assert m.yaw_of(m.quaternion(yaw)) == pytest.approx(yaw)
    assert m.yaw_of({"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0}) == 0.0


def test_sensor_impact_follows_the_nodes_rule():
    pose = Pose2D(0, 0, 0)
    bumper = BasicSensorInfo(1, SensorType.BUMPER, ImpactType.DIGITAL, pose, 10.0)
    sonar = BasicSensorInfo(2, SensorType.SONAR, ImpactType.ANALOG, pose, 10.0)
    cliff = BasicSensorInfo(3, SensorType.CLIFF, ImpactType.ANALOG, pose, 10.0)
    assert m.sensor_value(bumper, BasicSensorValue(False, 0.0))["value"]["is_in_impact"]
    assert not m.sensor_value(bumper, BasicSensorValue(False, 1.0))["value"]["is_in_impact"]
    assert m.sensor_value(sonar, BasicSensorValue(False, 1.5))["value"]["is_in_impact"]
    assert not m.sensor_value(cliff, BasicSensorValue(True, 0.0))["value"]["is_in_impact"]

"""The guess check behind /set_initialpose, on the simulator's own map and lidar frame."""

from __future__ import annotations

import math

import pytest

from hitrobot_server.robot.factory import build_simulator
from hitrobot_server.robot.model import MapRegion, Pose2D, Rect
from hitrobot_server.robot.relocalization import MATCH_SCORE, carry_forward, refine_guess


@pytest.fixture(scope="module")
def seen():
    sim = build_simulator(None, 0, False)
    sim.step(0.5)
    return sim.true_pose, sim.latest_scan, sim.map.map_region(Rect(-5, -5, 40, 30))


@pytest.mark.parametrize("dx, dy, dyaw", [(0.5, -0.4, 0.4), (-0.7, 0.3, -0.5), (0.0, 0.0, 0.0)])
def test_a_guess_off_by_up_to_a_metre_is_refined_to_the_truth(seen, dx, dy, dyaw):
    truth, scan, region = seen
    found = refine_guess(region, scan, Pose2D(truth.x + dx, truth.y + dy, truth.yaw + dyaw))
    assert found.good and found.score > 0.9
    assert math.hypot(found.pose.x - truth.x, found.pose.y - truth.y) < 0.05
    assert abs(math.remainder(found.pose.yaw - truth.yaw, math.tau)) < 0.03


@pytest.mark.parametrize("guess", [(3.0, 0.0, math.pi), (3.0, 0.0, 0.0), (1.5, 0.0, 0.0)])
def test_a_guess_that_does_not_contain_the_truth_is_not_good(seen, guess):
    truth, scan, region = seen
    found = refine_guess(region, scan, Pose2D(truth.x + guess[0], truth.y + guess[1],
                                              truth.yaw + guess[2]))
    assert not found.good and found.score < MATCH_SCORE


def test_no_map_is_no_match(seen):
    _truth, scan, region = seen
    empty = MapRegion(region.origin_x, region.origin_y, region.resolution,
                      region.cells[:0, :0])
    assert not refine_guess(empty, scan, Pose2D(0, 0, 0)).good


def test_carry_forward_adds_the_motion_since_the_scan():
    moved = carry_forward(Pose2D(1.0, 2.0, math.pi / 2), Pose2D(5.0, 5.0, 0.0),
                          Pose2D(6.0, 5.0, 0.0))  # one metre ahead since the scan
    assert moved.x == pytest.approx(1.0) and moved.y == pytest.approx(3.0)
    assert moved.yaw == pytest.approx(math.pi / 2)

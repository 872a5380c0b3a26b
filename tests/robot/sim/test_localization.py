import math

from hitrobot_server.robot.model import (
    ActionResult,
    LocalizationMovement,
    Point2D,
    Pose2D,
    Rect,
)
from hitrobot_server.robot.planning.geometry import wrap_angle
from hitrobot_server.robot.sim.health import LOCALIZATION_LOW, RELOCALIZATION_FAILED
from hitrobot_server.robot.sim.simulator import Simulator

FAR = Pose2D(8.0, 8.3, 0.6)


def _error(sim):
    b, t = sim.pose, sim.true_pose
    return math.hypot(b.x - t.x, b.y - t.y), abs(wrap_angle(b.yaw - t.yaw))


def _recover(sim, run_until, **kwargs):
    info = sim.actions.recover_localization(**kwargs)
    assert run_until(sim, lambda: sim.actions.action(info.action_id).done, 30.0, dt=0.025)
    return sim.actions.action(info.action_id)


def test_quality_is_high_when_well_localized(world):
    sim = Simulator(world, seed=0)
    sim.step(1.0)
    assert sim.localization_quality >= 80
    assert not sim.health().has_error


def test_set_pose_far_away_drops_quality_and_recover_restores_it(world, run_until):
    sim = Simulator(world, seed=0)
    sim.set_pose(FAR)
    sim.step(2.0)
    assert _error(sim)[0] > 2.5  # a big error is not tracked away
    assert sim.localization_quality < 30
    assert LOCALIZATION_LOW in [e.error_code for e in sim.health().errors]
    result = _recover(sim, run_until, area=Rect(3.0, 6.5, 4.0, 3.0))
    assert result.result == ActionResult.SUCCESS
    distance, angle = _error(sim)
    assert distance < 0.1 and angle < 0.05
    sim.step(2.0)
    assert sim.localization_quality >= 80
    assert not sim.health().has_error


def test_global_recovery_searches_the_whole_map(world, run_until):
    sim = Simulator(world, seed=0)
    sim.set_pose(Pose2D(15.0, 3.3, 2.5))
    sim.step(0.5)
    result = _recover(sim, run_until, movement=LocalizationMovement.ROTATE_ONLY)
    assert result.result == ActionResult.SUCCESS
    assert _error(sim)[0] < 0.1


def test_recovery_in_the_wrong_area_fails_and_is_reported(world, run_until):
    sim = Simulator(world, seed=0)
    sim.set_pose(FAR)
    sim.step(0.5)
    result = _recover(sim, run_until, area=Rect(18.5, 9.5, 4.0, 1.0))
    assert result.result == ActionResult.FAILED and "relocalization" in result.reason
    assert RELOCALIZATION_FAILED in [e.error_code for e in sim.health().errors]
    assert sim.clear_health_error(RELOCALIZATION_FAILED)
    assert RELOCALIZATION_FAILED not in [e.error_code for e in sim.health().errors]


def test_recovery_times_out(world, run_until):
    sim = Simulator(world, seed=0)
    sim.set_pose(FAR)
    result = _recover(sim, run_until, max_time_ms=50)  # a global search needs longer
    assert result.result == ActionResult.FAILED and result.reason == "relocalization timed out"


def test_small_errors_are_tracked_away(world):
    sim = Simulator(world, seed=0)
    sim.set_pose(Pose2D(5.2, 8.1, 0.1))
    sim.step(3.0)
    distance, angle = _error(sim)
    assert distance < 0.01 and angle < 0.01


def test_disabled_localization_reports_zero_and_drifts(world, run_until):
    sim = Simulator(world, seed=0)
    sim.localization_enabled = False
    assert sim.localization_quality == 0
    info = sim.actions.move_to([Point2D(15.0, 8.0)])
    assert run_until(sim, lambda: sim.actions.action(info.action_id).done, 60.0)
    assert sim.localization_quality == 0
    assert not any(e.error_code == LOCALIZATION_LOW for e in sim.health().errors)
    assert _error(sim)[0] > 0.0
    sim.localization_enabled = True
    sim.step(3.0)
    assert sim.localization_quality > 0

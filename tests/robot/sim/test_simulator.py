import math

import pytest

from hitrobot_server.robot.model import (
    ActionDirection,
    ActionResult,
    ActionStatus,
    ArtifactUsage,
    DockingStatus,
    HealthLevel,
    Line,
    MoveOptionFlag,
    MoveOptions,
    Point2D,
    Pose2D,
)
from hitrobot_server.robot.planning.geometry import wrap_angle
from hitrobot_server.robot.sim.health import POWER_LOW
from hitrobot_server.robot.sim.power import PowerConfig
from hitrobot_server.robot.sim.simulator import SimConfig, Simulator

PRECISE_YAW = MoveOptionFlag.PRECISE | MoveOptionFlag.WITH_YAW


def _finished(sim, action_id):
    return lambda: sim.actions.action(action_id).done


def test_move_to_precise_with_yaw_reaches_the_goal(world, run_until):
    sim = Simulator(world, seed=0)
    goal, yaw = Point2D(20.0, 5.5), -2.0
    info = sim.actions.move_to([goal], MoveOptions(flags=PRECISE_YAW), yaw)
    assert info.status == ActionStatus.NEW_BORN
    assert info.action_name == "slamtec.agent.actions.MoveToAction"
    sim.step(0.1)
    assert sim.actions.current_action().status == ActionStatus.WORKING
    assert run_until(sim, _finished(sim, info.action_id), 120.0)
    assert sim.actions.action(info.action_id).succeeded
    for pose in (sim.pose, sim.true_pose):
        assert math.hypot(pose.x - goal.x, pose.y - goal.y) < 0.1
        assert abs(wrap_angle(pose.yaw - yaw)) < 0.1
    assert sim.actions.current_action() is None and sim.actions.remaining_path() == []


def test_path_and_milestones_are_reported_while_moving(world, run_until):
    sim = Simulator(world, seed=0)
    targets = [Point2D(10.0, 8.0), Point2D(14.5, 11.0)]
    info = sim.actions.move_to(targets)
    assert info.action_name.endswith("SeriesMoveToAction")
    assert run_until(sim, lambda: len(sim.actions.remaining_path()) > 1, 5.0)
    path = sim.actions.remaining_path()
    assert math.hypot(path[0].x - sim.pose.x, path[0].y - sim.pose.y) < 1e-9
    assert sim.actions.remaining_milestones() == targets
    assert run_until(sim, lambda: len(sim.actions.remaining_milestones()) == 1, 60.0)
    assert run_until(sim, _finished(sim, info.action_id), 60.0)
    assert sim.actions.action(info.action_id).succeeded


def test_appending_extends_the_running_move(world, run_until):
    sim = Simulator(world, seed=0)
    first = sim.actions.move_to([Point2D(9.0, 8.0)])
    sim.step(1.0)
    appended = sim.actions.move_to([Point2D(9.0, 8.5)], MoveOptions(flags=MoveOptionFlag.APPENDING))
    assert appended.action_id == first.action_id
    assert sim.actions.remaining_milestones() == [Point2D(9.0, 8.0), Point2D(9.0, 8.5)]
    assert run_until(sim, _finished(sim, first.action_id), 60.0)
    assert math.hypot(sim.pose.x - 9.0, sim.pose.y - 8.5) < 0.15


def test_a_new_action_aborts_the_current_one(world):
    sim = Simulator(world, seed=0)
    first = sim.actions.move_to([Point2D(20.0, 8.0)])
    sim.step(1.0)
    second = sim.actions.rotate(1.0)
    old = sim.actions.action(first.action_id)
    assert old.status == ActionStatus.DONE and old.result == ActionResult.ABORTED
    assert sim.actions.current_action().action_id == second.action_id


def test_cancel_stops_the_robot(world, run_until):
    sim = Simulator(world, seed=0)
    info = sim.actions.move_to([Point2D(20.0, 8.0)])
    assert run_until(sim, lambda: sim.odometry().twist.vx > 0.5, 20.0)
    cancelled = sim.actions.cancel_action()
    assert cancelled.result == ActionResult.ABORTED and cancelled.reason == "cancelled"
    assert sim.actions.current_action() is None
    sim.step(1.0)
    assert sim.odometry().twist.vx == 0.0
    x = sim.true_pose.x
    sim.step(2.0)
    assert sim.true_pose.x == x
    assert sim.actions.action(info.action_id).result == ActionResult.ABORTED
    assert sim.actions.cancel_action() is None


def test_go_home_docks_and_charges(world, run_until):
    sim = Simulator(world, seed=0)
    assert sim.power_status().docking_status == DockingStatus.NOT_ON_DOCK
    info = sim.actions.go_home()
    assert run_until(sim, _finished(sim, info.action_id), 120.0)
    assert sim.actions.action(info.action_id).succeeded
    status = sim.power_status()
    assert status.is_dc_in and status.is_charging
    assert status.docking_status == DockingStatus.ON_DOCK
    before = sim._battery.percentage
    sim.step(10.0)
    assert sim._battery.percentage > before
    again = sim.actions.go_home()
    sim.step(0.1)
    assert sim.actions.action(again.action_id).succeeded


def test_go_home_without_a_dock_fails(world):
    sim = Simulator(world, seed=0)
    sim.map._home = None
    info = sim.actions.go_home()
    sim.step(0.1)
    result = sim.actions.action(info.action_id)
    assert result.result == ActionResult.FAILED and "dock" in result.reason


def test_driving_into_a_wall_triggers_the_bumper(world, run_until):
    sim = Simulator(world, seed=0)
    info = sim.actions.rotate_to(math.pi / 2)
    assert run_until(sim, _finished(sim, info.action_id), 10.0)
    assert not any(v.is_in_impact for k, v in sim.sensor_values().items() if k < 3)

    def bumped():
        sim.actions.set_velocity(0.4, 0.0)
        return sim.sensor_values()[0].is_in_impact and sim.sensor_values()[1].is_in_impact

    assert run_until(sim, bumped, 10.0)
    pose = sim.true_pose
    assert sim._clearance(pose.x, pose.y) >= world_radius(sim) - 1e-9
    assert pose.y < 9.0 - 0.19
    sim.step(1.5)  # the dead-man timeout stops the push, then the bumper latch expires
    assert not sim.sensor_values()[0].is_in_impact
    assert sim.actions.current_action() is None


def world_radius(sim):
    return sim.config.drive.radius


def test_collision_during_navigation_forces_a_replan(world, run_until):
    sim = Simulator(world, seed=0)
    sim.set_pose(Pose2D(5.0, 7.6, 0.0))  # believes it is 0.4 m south of where it is
    sim.localization_enabled = False
    info = sim.actions.move_to([Point2D(5.0, 8.65)], MoveOptions(fail_retry_count=1), 0.0)
    run_until(sim, _finished(sim, info.action_id), 60.0)
    result = sim.actions.action(info.action_id)
    assert result.result == ActionResult.FAILED and result.reason == "blocked by an obstacle"


def test_velocity_commands_stop_after_the_dead_man_timeout(world):
    sim = Simulator(world, seed=0)
    sim.actions.set_velocity(0.3, 0.0)
    sim.step(0.4)
    assert sim.odometry().twist.vx > 0.2
    assert sim.actions.current_action().action_name.endswith("VelocityControlAction")
    sim.step(1.0)
    assert sim.odometry().twist.vx == 0.0
    assert sim.actions.current_action() is None


def test_move_by_and_rotate(world, run_until):
    sim = Simulator(world, seed=0)
    info = sim.actions.move_by_direction(ActionDirection.FORWARD, MoveOptions(speed_ratio=0.5), 1.0)
    assert run_until(sim, _finished(sim, info.action_id), 5.0)
    sim.step(1.0)
    assert 0.2 < sim.true_pose.x - 5.0 < 0.45
    info = sim.actions.rotate(2.5 * math.pi)
    turned, last = 0.0, sim.true_pose.yaw

    def done():
        nonlocal turned, last
        turned += wrap_angle(sim.true_pose.yaw - last)
        last = sim.true_pose.yaw
        return sim.actions.action(info.action_id).done

    assert run_until(sim, done, 30.0, dt=0.025)
    assert turned == pytest.approx(2.5 * math.pi, abs=0.05)


def test_unreachable_target_fails_with_a_reason(world, run_until):
    sim = Simulator(world, seed=0)
    info = sim.actions.move_to(
        [Point2D(9.75, 2.2)], MoveOptions(flags=MoveOptionFlag.RETURN_UNREACHABLE_DIRECTLY)
    )
    assert run_until(sim, _finished(sim, info.action_id), 5.0)
    result = sim.actions.action(info.action_id)
    assert result.result == ActionResult.FAILED and "occupied" in result.reason


def test_virtual_wall_is_respected_by_a_real_move(world, run_until):
    sim = Simulator(world, seed=0)
    sim.map.add_lines(ArtifactUsage.VIRTUAL_WALL, [Line(0, Point2D(12.0, 6.9), Point2D(12.0, 9.1))])
    info = sim.actions.move_to([Point2D(20.0, 8.0)])
    lowest = math.inf

    def done():
        nonlocal lowest
        lowest = min(lowest, sim.true_pose.y)
        assert not (11.8 < sim.true_pose.x < 12.2 and sim.true_pose.y > 6.85)
        return sim.actions.action(info.action_id).done

    assert run_until(sim, done, 120.0)
    assert sim.actions.action(info.action_id).succeeded
    assert lowest < 6.5  # went round through the open-plan office


def test_key_points_moves_along_a_virtual_track(world, run_until):
    sim = Simulator(world, seed=0)
    track = Line(0, Point2D(4.0, 7.6), Point2D(16.0, 7.6))
    sim.map.add_lines(ArtifactUsage.VIRTUAL_TRACK, [track])
    info = sim.actions.move_to([Point2D(15.0, 8.3)], MoveOptions(flags=MoveOptionFlag.KEY_POINTS))
    off_track = 0.0

    def done():
        nonlocal off_track
        pose = sim.true_pose
        if 6.0 < pose.x < 14.0:
            off_track = max(off_track, abs(pose.y - 7.6))
        return sim.actions.action(info.action_id).done

    assert run_until(sim, done, 60.0)
    assert sim.actions.action(info.action_id).succeeded
    assert off_track < 0.1


def test_lines_keep_ids_and_assign_fresh_ones(world):
    sim = Simulator(world, seed=0)
    wall = ArtifactUsage.VIRTUAL_WALL
    stored = sim.map.add_lines(
        wall, [Line(7, Point2D(0, 0), Point2D(1, 0)), Line(0, Point2D(0, 1), Point2D(1, 1))]
    )
    assert stored[0].id == 7 and stored[1].id not in (0, 7)
    clash = sim.map.add_lines(ArtifactUsage.VIRTUAL_TRACK, [Line(7, Point2D(0, 0), Point2D(1, 0))])
    assert clash[0].id != 7
    assert sim.map.move_lines(wall, [Line(7, Point2D(5, 5), Point2D(6, 6))])
    assert not sim.map.move_lines(wall, [Line(99, Point2D(5, 5), Point2D(6, 6))])
    assert sim.map.get_lines(wall)[0].start == Point2D(5, 5)
    assert sim.map.remove_line(wall, 7) and not sim.map.remove_line(wall, 7)
    sim.map.clear_lines(wall)
    assert sim.map.get_lines(wall) == []


def test_composite_map_round_trip(world):
    sim = Simulator(world, seed=0)
    sim.map.add_lines(ArtifactUsage.VIRTUAL_TRACK, [Line(3, Point2D(1, 8), Point2D(9, 8))])
    sim.map.home_pose = Pose2D(3.5, 0.6, 1.5)
    data = sim.map.composite_map()
    other = Simulator(world, seed=1, config=SimConfig(prebuilt_map=False))
    other.load_composite_map(data, Pose2D(5.0, 8.0, 0.0))
    assert other.map.get_lines(ArtifactUsage.VIRTUAL_TRACK) == sim.map.get_lines(
        ArtifactUsage.VIRTUAL_TRACK
    )
    assert other.home_pose == Pose2D(3.5, 0.6, 1.5)
    assert (other.map.map_region().cells == sim.map.map_region().cells).all()
    with pytest.raises(ValueError):
        other.load_composite_map(b"junk", Pose2D(0, 0, 0))


def test_time_slicing_does_not_change_the_run(world):
    a = Simulator(world, seed=3)
    b = Simulator(world, seed=3)
    for sim in (a, b):
        sim.actions.move_to([Point2D(12.0, 4.0)])
    a.step(6.0)
    for _ in range(150):
        b.step(0.04)
    assert a.time == b.time == pytest.approx(6.0)
    assert a.true_pose == b.true_pose
    assert (a.latest_scan.ranges == b.latest_scan.ranges).all()


def test_battery_drains_and_warns_when_low(world):
    sim = Simulator(world, seed=0, config=SimConfig(initial_battery=15.05, power=PowerConfig()))
    assert not sim.health().has_warning
    sim.actions.set_velocity(0.5, 0.0)
    sim.step(0.5)
    sim.step(10.0)
    assert sim.power_status().battery_percentage <= 15
    health = sim.health()
    assert [e.error_code for e in health.errors] == [POWER_LOW]
    assert health.errors[0].level == HealthLevel.WARN


def test_device_info_and_sensors(world):
    sim = Simulator(world, seed=9)
    info = sim.device_info()
    assert len(info.device_id) == 32 and info.device_id == info.device_id.upper()
    assert {s.id for s in sim.sensors_info()} == set(sim.sensor_values())
    front_sonar = sim.sensor_values()[6]
    assert front_sonar.is_in_impact and 0.0 < front_sonar.value <= 2.0


@pytest.mark.parametrize(
    "call",
    [
        lambda s: s.actions.move_to([]),
        lambda s: s.actions.move_to([Point2D(math.nan, 0.0)]),
        lambda s: s.actions.set_velocity(math.inf, 0.0),
        lambda s: s.actions.move_by_direction(ActionDirection.FORWARD, duration=0.0),
        lambda s: s.set_pose(Pose2D(0.0, math.nan, 0.0)),
        lambda s: s.step(-1.0),
    ],
)
def test_bad_arguments_raise_value_error(world, call):
    with pytest.raises(ValueError):
        call(Simulator(world, seed=0))

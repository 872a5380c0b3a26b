import asyncio
import math

import pytest

from hitrobot_server.robot.backend import (
    BackendError,
    NotConnectedError,
    UnsupportedError,
)
from hitrobot_server.robot.model import (
    ArtifactUsage,
    Line,
    MapKind,
    MoveOptionFlag,
    MoveOptions,
    Point2D,
    Pose2D,
)
from hitrobot_server.robot.sim.backend import SimBackend
from hitrobot_server.robot.sim.simulator import Simulator
from tests.robot.test_composed import PROTOCOLS, capabilities


@pytest.fixture
async def backend(world):
    sim_backend = SimBackend(Simulator(world, seed=0), rate_hz=40.0, time_scale=10.0)
    await sim_backend.link.start()
    yield sim_backend
    await sim_backend.link.stop()


async def _wait(predicate, seconds=10.0):
    for _ in range(round(seconds / 0.01)):
        if await predicate():
            return True
        await asyncio.sleep(0.01)
    return False


def test_every_interface_method_is_implemented(world):
    backend = SimBackend(Simulator(world, seed=0))
    for part, protocol in zip(capabilities(backend), PROTOCOLS, strict=True):
        assert not type(part).__abstractmethods__
        assert protocol in type(part).__mro__  # one adapter per capability, as REST's


async def test_requests_fail_while_stopped(world):
    sim_backend = SimBackend(Simulator(world, seed=0))
    assert not sim_backend.link.connected
    with pytest.raises(NotConnectedError):
        await sim_backend.localization.get_pose()
    await sim_backend.link.start()
    assert sim_backend.link.connected
    assert await sim_backend.localization.get_pose() == world.start_pose
    await sim_backend.link.stop()
    await sim_backend.link.stop()
    assert not sim_backend.link.connected


async def test_the_stepping_task_advances_simulated_time(backend):
    first = (await backend.sensors.get_laser_scan()).stamp

    async def later():
        return (await backend.sensors.get_odometry()).stamp > first + 1.0

    assert await _wait(later, 5.0)
    assert (await backend.sensors.get_laser_scan()).stamp > first
    assert backend.runner.max_step_seconds < 0.25


async def test_move_through_the_backend(backend):
    info = await backend.motion.move_to(
        [Point2D(9.0, 8.0)],
        MoveOptions(flags=MoveOptionFlag.PRECISE | MoveOptionFlag.WITH_YAW),
        1.0,
    )

    async def finished():
        return (await backend.motion.get_action(info.action_id)).done

    assert await _wait(finished, 20.0)
    assert (await backend.motion.get_action(info.action_id)).succeeded
    assert await backend.motion.get_current_action() is None
    pose = await backend.localization.get_pose()
    assert math.hypot(pose.x - 9.0, pose.y - 8.0) < 0.1


async def test_state_getters_answer(backend):
    region = await backend.maps.get_map()
    area = await backend.maps.get_known_area()
    assert region.width == round(area.width / region.resolution)
    assert 0 <= await backend.localization.get_localization_quality() <= 100
    assert await backend.localization.get_localization_enabled()
    assert not await backend.maps.get_map_update()
    await backend.maps.set_map_update(True)
    assert await backend.maps.get_map_update()
    assert (await backend.power.get_power_status()).battery_percentage == 80
    assert 30 <= await backend.power.get_board_temperature() <= 50
    sensors = backend.sensors
    assert len(await sensors.get_sensors_info()) == len(await sensors.get_sensor_values())
    assert (await backend.sensors.get_device_info()).model_name == "hitrobot-sim"
    assert not (await backend.sensors.get_health()).has_error
    assert await backend.maps.get_home_pose() is not None
    assert await backend.motion.get_remaining_path() == []
    assert await backend.motion.get_remaining_milestones() == []


async def test_errors_are_translated(backend):
    with pytest.raises(UnsupportedError):
        await backend.maps.get_map(kind=MapKind.SWEEPERMAP)
    with pytest.raises(BackendError):
        await backend.motion.move_to([])
    with pytest.raises(BackendError):
        await backend.maps.set_composite_map(b"nope", Pose2D(0.0, 0.0, 0.0))


async def test_lines_and_composite_map(backend):
    stored = await backend.maps.add_lines(
        ArtifactUsage.VIRTUAL_WALL, [Line(0, Point2D(1.0, 1.0), Point2D(2.0, 1.0))]
    )
    assert await backend.maps.get_lines(ArtifactUsage.VIRTUAL_WALL) == stored
    data = await backend.maps.get_composite_map()
    await backend.maps.clear_lines(ArtifactUsage.VIRTUAL_WALL)
    await backend.maps.set_composite_map(data, Pose2D(5.0, 8.0, 0.0))
    assert await backend.maps.get_lines(ArtifactUsage.VIRTUAL_WALL) == stored


async def test_velocity_and_cancel(backend):
    await backend.motion.set_velocity(0.3, 0.0)

    async def moving():
        return (await backend.sensors.get_odometry()).twist.vx > 0.1

    assert await _wait(moving, 2.0)
    cancelled = await backend.motion.cancel_action()
    assert cancelled is not None and cancelled.reason == "cancelled"
    assert await backend.motion.cancel_action() is None

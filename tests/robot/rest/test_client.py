"""``SlamwareRestBackend`` over real HTTP: against the sim-device for every method, and against
a scripted fake robot for the failures and quirks a simulator never shows."""

from __future__ import annotations

import asyncio
import math

import pytest
from aiohttp import web

from hitrobot_server.config import Settings
from hitrobot_server.robot.backend import BackendError, NotConnectedError, UnsupportedError
from hitrobot_server.robot.device import SimDevice
from hitrobot_server.robot.factory import build_backend, build_simulator
from hitrobot_server.robot.model import (
    ActionDirection,
    ActionResult,
    ArtifactUsage,
    Line,
    MapKind,
    MoveOptionFlag,
    MoveOptions,
    Point2D,
    Pose2D,
    Rect,
)
from hitrobot_server.robot.rest import paths, shapes
from hitrobot_server.robot.rest.client import SlamwareRestBackend
from tests.robot.rest.conftest import connected


async def until(predicate, seconds: float = 10.0):
    for _ in range(round(seconds / 0.02)):
        value = await predicate()
        if value:
            return value
        await asyncio.sleep(0.02)
    raise AssertionError("condition not met in time")


# --- against the sim-device ------------------------------------------------------------------


async def test_state_reads_match_the_simulator(device, client):
    sim = device.simulator
    pose = await client.localization.get_pose()
    assert math.hypot(pose.x - sim.pose.x, pose.y - sim.pose.y) < 0.05
    odopose = await client.get_odopose()  # the device serves the localized pose
    assert math.hypot(odopose.x - pose.x, odopose.y - pose.y) < 0.05
    odo = await client.sensors.get_odometry()
    assert odo.twist.vx == 0.0 and odo.pose.x == pytest.approx(pose.x, abs=0.05)
    scan = await client.sensors.get_laser_scan()
    assert len(scan.angles) == len(sim.latest_scan.angles) and scan.valid.sum() > 300
    assert await client.maps.get_known_area() == sim.map.known_area()
    assert await client.maps.get_map_update() is False
    assert await client.localization.get_localization_enabled() is True
    assert 0 <= await client.localization.get_localization_quality() <= 100
    power = await client.power.get_power_status()
    assert power == sim.power_status()
    info = await client.sensors.get_device_info()
    assert info.model_name == "hitrobot-sim" and info.device_id == sim.device_info().device_id
    assert "REST" in info.sdk_version
    assert await client.sensors.get_health() == sim.health()
    assert await client.maps.get_home_pose() == sim.home_pose
    assert await client.power.get_board_temperature() == 0
    assert await client.sensors.get_sensors_info() == []
    assert await client.sensors.get_sensor_values() == {}


async def test_map_kinds_other_than_explore_are_unsupported(client):
    with pytest.raises(UnsupportedError):
        await client.maps.get_map(None, MapKind.SLAMMAP)
    with pytest.raises(UnsupportedError):
        await client.maps.set_map_update(True, MapKind.SWEEPERMAP)


async def test_setters_reach_the_simulator(device, client):
    sim = device.simulator
    await client.maps.set_map_update(True)
    assert sim.map.map_update is True and await client.maps.get_map_update() is True
    await client.localization.set_localization_enabled(False)
    assert sim.localization_enabled is False
    assert await client.localization.get_localization_quality() == 0
    await client.localization.set_localization_enabled(True)
    await client.maps.set_home_pose(Pose2D(1.0, 2.0, 0.5))
    assert sim.home_pose == Pose2D(1.0, 2.0, 0.5)
    await client.localization.set_pose(Pose2D(6.0, 8.0, 0.1))
    assert sim.pose.x == pytest.approx(6.0) and sim.pose.yaw == pytest.approx(0.1)
    with pytest.raises(BackendError):
        await client.localization.set_pose(Pose2D(math.nan, 0.0, 0.0))
    await client.maps.clear_map()
    assert sim.map.known_area().is_empty
    assert (await client.maps.get_map()).cells.size == 0
    assert not await client.sensors.clear_health_error(0x12345)


async def test_stcm_is_passed_through_unchanged_and_the_pose_is_set_after(device, client):
    sim = device.simulator
    saved = await client.maps.get_composite_map()
    assert saved == sim.map.composite_map()
    await client.maps.clear_map()
    await client.maps.set_composite_map(saved, Pose2D(5.0, 8.0, 0.0))
    assert sim.map.composite_map() == saved
    assert sim.pose.x == pytest.approx(5.0) and sim.pose.y == pytest.approx(8.0)
    with pytest.raises(BackendError, match="HTTP 400"):
        await client.maps.set_composite_map(b"not a map", Pose2D(5.0, 8.0, 0.0))


async def test_an_action_is_followed_to_its_end_and_idle_is_none(client):
    assert await client.motion.get_current_action() is None  # 404 when idle
    assert await client.motion.cancel_action() is None
    flags = MoveOptionFlag.PRECISE | MoveOptionFlag.WITH_YAW
    action = await client.motion.move_to([Point2D(6.0, 8.0)], MoveOptions(flags=flags), 1.0)
    assert action.action_name == shapes.MOVE_TO and not action.done
    current = await until(client.motion.get_current_action)
    assert current.action_id == action.action_id
    assert await client.motion.get_remaining_milestones() == [Point2D(6.0, 8.0)]

    async def finished():
        info = await client.motion.get_action(action.action_id)
        return info if info.done else None

    final = await until(finished, 30)
    assert final.result is ActionResult.SUCCESS and final.action_name == ""  # a gravestone
    pose = await client.localization.get_pose()
    assert math.hypot(pose.x - 6.0, pose.y - 8.0) < 0.1 and abs(pose.yaw - 1.0) < 0.1
    assert await client.motion.get_current_action() is None
    assert await client.motion.get_action(10_000) is None


async def test_plans_are_local_and_unreachable_targets_refused(device, client):
    """compute_path plans on the robot's map without moving it; RETURN_UNREACHABLE_DIRECTLY
    refuses an occupied target before anything is sent."""
    before = device.simulator.true_pose
    path = await client.motion.compute_path(None, Pose2D(10.0, 12.5, 0.0))
    assert math.dist((path[-1].x, path[-1].y), (10.0, 12.5)) < 0.01 and len(path) > 2
    assert device.simulator.true_pose == before
    with pytest.raises(BackendError, match="occupied"):
        await client.motion.move_to([Point2D(9.75, 2.2)],
                             MoveOptions(flags=MoveOptionFlag.RETURN_UNREACHABLE_DIRECTLY))


async def test_cancel_returns_the_final_state(client):
    await client.motion.move_to([Point2D(20.0, 8.2)])
    assert await until(client.motion.get_remaining_path)
    final = await client.motion.cancel_action()
    assert final.done and final.result is ActionResult.ABORTED
    assert await client.motion.get_remaining_path() == []


async def test_appending_adds_the_targets_behind_the_remaining_ones(client):
    await client.motion.move_to([Point2D(12.0, 8.2)])
    appended = await client.motion.move_to([Point2D(14.0, 8.2)],
                                    MoveOptions(flags=MoveOptionFlag.APPENDING))
    assert appended.action_name == shapes.SERIES_MOVE_TO
    assert await client.motion.get_remaining_milestones() == [Point2D(12.0, 8.2),
                                                              Point2D(14.0, 8.2)]
    await client.motion.cancel_action()
    alone = await client.motion.move_to([Point2D(6.0, 8.0)],
                                        MoveOptions(flags=MoveOptionFlag.APPENDING))
    assert alone.action_name == shapes.MOVE_TO  # nothing to append to
    await client.motion.cancel_action()


async def test_manual_moves_rotations_home_and_relocalization_start(client):
    for start in (client.motion.move_by_direction(ActionDirection.TURNLEFT, duration=0.2),
                  client.motion.move_by_theta(0.3, duration=0.2),
                  client.motion.rotate_to(1.0), client.motion.rotate(-0.5), client.motion.go_home(),
                  client.localization.recover_localization(Rect(4, 7, 2, 2), 2000)):
        info = await start
        assert info.action_name.startswith(shapes.ACTION_PREFIX) and not info.done
    with pytest.raises(BackendError, match="direction"):
        await client.motion.move_by_direction(7)
    with pytest.raises(BackendError):
        await client.localization.recover_localization(None, 0)


async def test_velocity_is_emulated_with_move_by_and_zero_stops():
    # real time: the MoveBy duration is robot time, the re-send pace wall time
    device = SimDevice(build_simulator(), port=0, time_scale=1.0)
    await device.start()
    client = SlamwareRestBackend(device.url)
    await client.link.start()
    try:
        await connected(client)
        sim = device.simulator
        x0, yaw0 = sim.true_pose.x, sim.true_pose.yaw
        ids = set()
        for _ in range(12):
            await client.motion.set_velocity(0.3, 0.1)
            current = await client.motion.get_current_action()
            assert current is not None and current.action_name == shapes.MOVE_BY
            ids.add(current.action_id)
            await asyncio.sleep(0.05)
        assert 2 <= len(ids) < 8  # re-sent about every quarter second, not on every call
        assert sim.true_pose.x > x0 + 0.05
        await client.motion.set_velocity(0.0, 0.0)
        assert await client.motion.get_current_action() is None
        yaw0 = sim.true_pose.yaw
        for _ in range(6):
            await client.motion.set_velocity(0.0, -1.8)  # turning in place: turn right, full speed
            await asyncio.sleep(0.05)
        assert math.remainder(sim.true_pose.yaw - yaw0, math.tau) < -0.05
        await client.motion.set_velocity(0.0, 0.0)
        with pytest.raises(BackendError):
            await client.motion.set_velocity(math.inf, 0.0)
    finally:
        await client.link.stop()
        await device.stop()


async def test_lines_crud_and_robot_assigned_ids(device, client):
    walls = ArtifactUsage.VIRTUAL_WALL
    stored = await client.maps.add_lines(walls, [Line(7, Point2D(1, 1), Point2D(2, 2)),
                                            Line(8, Point2D(3, 1), Point2D(3, 4))])
    assert [(ln.start, ln.end) for ln in stored] == [(Point2D(1, 1), Point2D(2, 2)),
                                                     (Point2D(3, 1), Point2D(3, 4))]
    assert len({ln.id for ln in stored}) == 2  # the robot's ids, not necessarily 7 and 8
    assert await client.maps.get_lines(walls) == stored
    assert await client.maps.get_lines(ArtifactUsage.VIRTUAL_TRACK) == []
    moved = Line(stored[0].id, Point2D(0, 0), Point2D(0, 1))
    assert await client.maps.move_lines(walls, [moved])
    assert not await client.maps.move_lines(walls, [Line(999, Point2D(0, 0), Point2D(0, 1))])
    assert (await client.maps.get_lines(walls))[0] == moved
    assert await client.maps.remove_line(walls, stored[1].id)
    assert not await client.maps.remove_line(walls, 999)
    await client.maps.clear_lines(walls)
    assert device.simulator.map.get_lines(walls) == []


async def test_blocked_areas_become_forbidden_rectangles_and_replace_only_ours(device, client):
    import aiohttp

    url = f"{device.url}{paths.RECTANGLE_AREAS}/forbidden_area"
    foreign = shapes.rectangle_area_json(Point2D(0, 0), Point2D(1, 0), 0.5,
                                         {"display_name": "someone else's"})
    async with aiohttp.ClientSession() as session, session.post(url, json=foreign) as resp:
        assert resp.status == 200
    square = [Point2D(8, 7), Point2D(9, 7), Point2D(9, 8), Point2D(8, 8)]
    triangle = [Point2D(12, 7), Point2D(13, 7), Point2D(12.5, 8)]
    await client.maps.set_blocked_areas([square, triangle])
    blocked = device.simulator.map.blocked
    assert len(blocked) == 1 + 1 + 10  # foreign + square + ten 0.1 m strips of the triangle
    await client.maps.set_blocked_areas([square])
    assert len(device.simulator.map.blocked) == 2
    await client.maps.set_blocked_areas([])
    assert len(device.simulator.map.blocked) == 1  # the foreign one stays


async def test_factory_builds_the_rest_client_from_a_url():
    from hitrobot_server.nodes.options import SlamwareParams

    settings = Settings.of(robot="http://192.0.2.1:1448/",
                        slamware=SlamwareParams(reconn_wait_ms=1234))
    backend = build_backend(settings.robot_options())
    assert isinstance(backend, SlamwareRestBackend)
    assert backend.url == "http://192.0.2.1:1448" and backend.link.reconn_wait == 1.234
    assert not backend.link.connected
    with pytest.raises(NotConnectedError):
        await backend.localization.get_pose()
    with pytest.raises(ValueError):
        SlamwareRestBackend("ftp://robot")


# --- against a scripted fake robot -----------------------------------------------------------


async def test_http_errors_and_false_become_backend_errors(fake, fake_client):
    fake.answer("GET", paths.POSE, "internal trouble", status=500, content_type="text/plain")
    with pytest.raises(BackendError, match=r"GET /api/core/slam/v1/localization/pose: "
                                           r"HTTP 500: internal trouble"):
        await fake_client.localization.get_pose()
    fake.answer("PUT", paths.MAPPING_ENABLE, "false")
    with pytest.raises(BackendError, match="answered false"):
        await fake_client.maps.set_map_update(True)
    fake.answer("PUT", paths.MAPPING_ENABLE, "", status=400, content_type="text/plain")
    with pytest.raises(BackendError, match="HTTP 400"):
        await fake_client.maps.set_map_update(True)
    fake.answer("PUT", paths.MAPPING_ENABLE, "true")
    await fake_client.maps.set_map_update(True)
    fake.answer("PUT", paths.POSE, "")  # an empty 200 is success
    await fake_client.localization.set_pose(Pose2D(0, 0, 0))
    fake.answer("POST", paths.ACTIONS, "Can not create action", status=400,
                content_type="text/plain")
    with pytest.raises(BackendError, match="could not start MoveToAction.*Can not create"):
        await fake_client.motion.move_to([Point2D(1, 1)])
    fake.answer("GET", paths.QUALITY, "not json", content_type="text/plain")
    with pytest.raises(BackendError, match="not JSON"):
        await fake_client.localization.get_localization_quality()
    fake.answer("GET", paths.POWER_STATUS, '{"dockingStatus": "on_dock"}')
    with pytest.raises(BackendError, match="unexpected answer"):
        await fake_client.power.get_power_status()
    assert fake_client.link.connected  # none of that is a lost connection


async def test_bare_json_values_404s_and_short_maps(fake, fake_client):
    fake.answer("GET", paths.QUALITY, "87")
    assert await fake_client.localization.get_localization_quality() == 87
    fake.answer("GET", paths.LOCALIZATION_ENABLE, "false")
    assert await fake_client.localization.get_localization_enabled() is False
    fake.answer("GET", paths.HOMEPOSE, "Home dock not found", 404, "text/plain")
    assert await fake_client.maps.get_home_pose() is None
    fake.answer("GET", paths.CURRENT_ACTION, "Action Not Found", 404, "text/plain")
    assert await fake_client.motion.get_current_action() is None
    # a robot that has no map yet: empty, too short, or 404
    for body, status in ((b"", 200), (b"\x00" * 20, 200), (b"", 404)):
        fake.answer("GET", paths.EXPLORE_MAP, body, status, "application/octet-stream")
        region = await fake_client.maps.get_map(Rect(1.0, 2.0, 3.0, 4.0))
        assert region.cells.size == 0 and region.resolution == 0.05
    fake.answer("GET", paths.EXPLORE_MAP, b"\x00" * 40, 200, "application/octet-stream")
    fake.answer("GET", paths.EXPLORE_MAP, bytes(32) + b"\x05\x00\x00\x00", 200,
                "application/octet-stream")
    with pytest.raises(BackendError, match="explore"):
        await fake_client.maps.get_map()
    fake.answer("GET", paths.lines(ArtifactUsage.VIRTUAL_TRACK), "", 404, "text/plain")
    assert await fake_client.maps.get_lines(ArtifactUsage.VIRTUAL_TRACK) == []
    fake.answer("GET", f"{paths.RECTANGLE_AREAS}/forbidden_area", "", 404, "text/plain")
    with pytest.raises(UnsupportedError, match="rectangle areas"):
        await fake_client.maps.set_blocked_areas([[Point2D(0, 0), Point2D(1, 0), Point2D(0, 1)]])


async def test_a_success_out_of_tolerance_is_a_failure(fake, fake_client):
    """A robot that calls a move a success while standing 0.6 m from its target: the move
    reads as FAILED with the distance, judged once when it ends (a later pose changes
    nothing); an in-tolerance success stays a success."""
    fake.answer("POST", paths.ACTIONS, '{"action_id": 7, "action_name": '
                '"slamtec.agent.actions.MoveToAction", "stage": "", '
                '"state": {"status": 1, "result": 0, "reason": ""}}')
    fake.answer("GET", f"{paths.ACTIONS}/7", '{"action_id": 7, '
                '"state": {"status": 4, "result": 0, "reason": ""}}')
    fake.answer("GET", paths.POSE, '{"x": 6.6, "y": 8.0, "z": 0, "yaw": 0, "pitch": 0, '
                '"roll": 0}')
    await fake_client.motion.move_to([Point2D(6.0, 8.0)], MoveOptions(acceptable_precision=0.2))
    judged = await fake_client.motion.get_action(7)
    assert judged.result is ActionResult.FAILED and "0.60 m" in judged.reason
    fake.answer("GET", paths.POSE, '{"x": 6.0, "y": 8.0, "z": 0, "yaw": 0, "pitch": 0, '
                '"roll": 0}')
    assert (await fake_client.motion.get_action(7)).result is ActionResult.FAILED
    await fake_client.motion.move_to([Point2D(6.1, 8.0)], MoveOptions(acceptable_precision=0.2))
    assert (await fake_client.motion.get_action(7)).result is ActionResult.SUCCESS


async def test_a_status_2_action_is_paused_not_finished(fake, fake_client):
    fake.answer("GET", f"{paths.ACTIONS}/5", '{"action_id": 5, "action_name": '
                '"slamtec.agent.actions.MoveToAction", "stage": "GOING_TO_TARGET", '
                '"state": {"status": 2, "result": 0, "reason": ""}}')
    info = await fake_client.motion.get_action(5)
    assert not info.done and info.status.name == "PAUSED"


async def test_identical_gets_share_one_request_and_each_resource_has_one_in_flight(
        fake, fake_client):
    active = {"now": 0, "max": 0}

    async def slow(request: web.Request) -> web.Response:
        active["now"] += 1
        active["max"] = max(active["max"], active["now"])
        await asyncio.sleep(0.05)
        active["now"] -= 1
        return web.Response(text='{"x": 1, "y": 2, "yaw": 0}', content_type="application/json")

    fake.on("GET", paths.POSE, slow)
    fake.seen.clear()
    poses = await asyncio.gather(*(fake_client.localization.get_pose() for _ in range(10)))
    assert all(p == Pose2D(1, 2, 0) for p in poses)
    assert fake.seen.count(("GET", paths.POSE)) == 1

    fake.on("GET", paths.EXPLORE_MAP, slow)  # different queries, same resource: one at a time
    fake.on("PUT", paths.POSE, slow)
    fake.seen.clear()
    await asyncio.gather(*(fake_client.link.request("GET", paths.EXPLORE_MAP, params={"min_x": i})
                           for i in range(4)),
                         *(fake_client.localization.set_pose(Pose2D(i, 0, 0)) for i in range(3)),
                         return_exceptions=False)
    assert fake.seen.count(("GET", paths.EXPLORE_MAP)) == 4
    assert fake.seen.count(("PUT", paths.POSE)) == 3
    assert active["max"] <= 2  # one map request and one pose PUT at most at any moment


async def test_timeouts_fail_the_request_and_a_silent_robot_is_lost(fake, fake_client):
    async def hang(request: web.Request) -> web.Response:
        await asyncio.sleep(5)
        return web.Response(text="0")

    fake.on("GET", paths.QUALITY, hang)
    fake.answer("GET", paths.LOCALIZATION_ENABLE, "true")
    with pytest.raises(BackendError, match="no answer within 0.3 s") as first:
        await fake_client.localization.get_localization_quality()
    assert not isinstance(first.value, NotConnectedError) and fake_client.link.connected
    assert await fake_client.localization.get_localization_enabled()  # others still answer
    await asyncio.sleep(0.4)  # nothing answered for more than twice the timeout now
    with pytest.raises(NotConnectedError):
        await fake_client.localization.get_localization_quality()
    assert not fake_client.link.connected
    fake.answer("GET", paths.QUALITY, "50")
    await connected(fake_client)  # back after reconn_wait_ms
    assert await fake_client.localization.get_localization_quality() == 50


async def test_a_robot_still_starting_is_not_connected(fake):
    ready = {"enabled": False}

    async def capabilities(request: web.Request) -> web.Response:
        return web.json_response([{"name": "slamware.agent.core", "version": "5.1.1",
                                   "enabled": ready["enabled"]}])

    fake.on("GET", paths.CAPABILITIES, capabilities)
    backend = SlamwareRestBackend(fake.url, reconn_wait_ms=100)
    await backend.link.start()
    try:
        await asyncio.sleep(0.35)
        assert not backend.link.connected
        with pytest.raises(NotConnectedError, match="not connected"):
            await backend.sensors.get_health()
        ready["enabled"] = True
        await connected(backend)
    finally:
        await backend.link.stop()
    assert not backend.link.connected


async def test_a_robot_without_capabilities_is_probed_with_robot_info(fake):
    fake.answer("GET", paths.CAPABILITIES, "", 404, "text/plain")
    fake.answer("GET", paths.ROBOT_INFO, '{"modelName": "old"}')
    backend = SlamwareRestBackend(fake.url, reconn_wait_ms=100)
    await backend.link.start()
    try:
        await connected(backend)
        assert (await backend.sensors.get_device_info()).model_name == "old"
    finally:
        await backend.link.stop()


async def test_reboot_goes_offline_and_comes_back_fresh(device, client):
    device.backend.runner.reboot_delay = 0.3
    old = device.simulator
    await client.localization.set_pose(Pose2D(6.0, 8.0, 0.0))
    await client.power.reboot()
    assert not client.link.connected
    with pytest.raises(NotConnectedError):
        await client.localization.get_pose()
    await connected(client, 5.0)
    assert device.simulator is not old
    pose = await client.localization.get_pose()
    assert (pose.x, pose.y) == (5.0, 8.0)  # the start pose again


async def test_power_off_goes_away_for_good(device, client):
    await client.power.power_off()
    assert not client.link.connected
    await asyncio.sleep(0.5)  # more than reconn_wait_ms: still gone
    assert not client.link.connected and not device.running

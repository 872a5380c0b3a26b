"""The locomotion gate in front of a backend, and the set_listen grammar (no server)."""

from __future__ import annotations

import asyncio

import pytest

from hitrobot_server.robot.backend import BackendError, NotConnectedError
from hitrobot_server.robot.factory import build_simulator, robot_of
from hitrobot_server.robot.locomotion import (
    ControlMode,
    JoyListenType,
    ListenError,
    ListenRequest,
    LocomotionState,
    parse_listen,
)
from hitrobot_server.robot.model import ActionDirection, Point2D
from hitrobot_server.robot.sim.backend import SimBackend
from tests.helpers import until


def test_parse_listen_formats():
    assert parse_listen("joy/gui<&>tablet-7") == ListenRequest("joy/gui", False, "tablet-7")
    assert parse_listen("vel_cmd/autonomy") == ListenRequest("vel_cmd/autonomy", False)
    assert parse_listen("joy/gui<&><CLOSE>") == ListenRequest("joy/gui", True)
    assert parse_listen(" vel_cmd/autonomy<&><CLOSE> ") == ListenRequest("vel_cmd/autonomy", True)
    for bad, needle in [("", "empty"), ("joy/gui", "network id"), ("joy/gui<&>", "network id"),
                        ("cmd_vel", "unknown control source"),
                        ("vel_cmd/autonomy<&>x", "no argument")]:
        with pytest.raises(ListenError, match=needle):
            parse_listen(bad)


def test_control_mode_claims_and_releases():
    mode = ControlMode()
    assert mode.listen_type == JoyListenType.VEL_CMD
    assert "from pad" in mode.apply(parse_listen("joy/gui<&>pad"))
    assert mode.listen_type == JoyListenType.JOY and mode.network_id == "pad"
    assert "nothing to release" in mode.apply(parse_listen("vel_cmd/autonomy<&><CLOSE>"))
    assert mode.listen_type == JoyListenType.JOY
    assert mode.apply(parse_listen("joy/gui<&><CLOSE>")) == "released joy/gui"
    assert mode.listen_type == JoyListenType.NONE and mode.network_id == ""
    mode.apply(parse_listen("vel_cmd/autonomy"))
    assert mode.listen_type == JoyListenType.VEL_CMD


async def test_sitting_refuses_every_motion_and_standing_up_allows_it():
    inner = SimBackend(build_simulator(), time_scale=4.0)
    robot = robot_of(inner, stand_up_seconds=0.2)
    motion, locomotion = robot.motion, robot.locomotion
    assert motion is not inner  # the nodes get the gated motion ...
    assert robot.localization is inner.localization and robot.power is inner.power  # ... the rest
    assert locomotion.state == LocomotionState.COMM_DISABLED  # not started
    with pytest.raises(NotConnectedError):
        await motion.move_to([Point2D(6.0, 8.0)])  # the inner backend's own refusal
    await robot.link.start()
    try:
        assert locomotion.state == LocomotionState.IN_CONTROL and locomotion.motion_allowed
        assert robot.simulator is inner.simulator
        await motion.move_to([Point2D(7.0, 8.0)])
        await locomotion.sit_down()
        assert locomotion.state == LocomotionState.SITDOWN_MODE
        assert not locomotion.motors_enabled
        assert await motion.get_current_action() is None  # sitting down stopped the move
        text = "motion refused: the robot is sitting (locomotion state SITDOWN_MODE)"
        for call in (lambda: motion.move_to([Point2D(6.0, 8.0)]),
                     lambda: motion.move_by_direction(ActionDirection.FORWARD),
                     lambda: motion.move_by_theta(0.5), lambda: motion.rotate_to(1.0),
                     lambda: motion.rotate(1.0), lambda: motion.go_home(),
                     lambda: motion.set_velocity(0.2, 0.0)):
            with pytest.raises(BackendError) as info:
                await call()
            assert str(info.value) == text
        await motion.set_velocity(0.0, 0.0)  # stopping is always allowed
        await robot.localization.get_pose()  # so is everything that does not move the robot
        await locomotion.stand_up()
        assert locomotion.state == LocomotionState.STANDING_MODE
        with pytest.raises(BackendError, match="still standing up"):
            await motion.rotate(0.3)
        await asyncio.sleep(0.3)
        assert locomotion.state == LocomotionState.IN_CONTROL
        info = await motion.rotate(0.3)
        assert info.action_id > 0
        await locomotion.stand_up()  # already up: nothing changes
        assert locomotion.state == LocomotionState.IN_CONTROL
    finally:
        await robot.link.stop()
    assert locomotion.state == LocomotionState.COMM_DISABLED


async def test_a_reboot_brings_the_locomotion_back_in_control():
    """A robot that sat down comes back from a reboot as freshly started: the bundle's reboot
    restarts the locomotion along with the robot (the gate never wraps power)."""
    inner = SimBackend(build_simulator(), time_scale=4.0)
    inner.runner.reboot_delay = 0.1
    robot = robot_of(inner, stand_up_seconds=0.2)
    await robot.link.start()
    try:
        await robot.locomotion.sit_down()
        with pytest.raises(BackendError, match="sitting"):
            await robot.motion.rotate(0.3)
        await robot.reboot()
        assert robot.locomotion.state == LocomotionState.COMM_DISABLED  # offline meanwhile
        await until(lambda: robot.connected, "the robot back from its reboot")
        assert robot.locomotion.state == LocomotionState.IN_CONTROL
        assert (await robot.motion.rotate(0.3)).action_id > 0
    finally:
        await robot.link.stop()

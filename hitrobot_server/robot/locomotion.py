"""The locomotion state machine and control mode, and the gate they put in front of motion.

:class:`Locomotion` is the state machine; :class:`GatedMotion` wraps a robot's motion
capability only (:class:`~hitrobot_server.robot.backend.MotionBackend`): its commands that move
the robot (``move_to``, ``move_by_direction``, ``move_by_theta``, ``rotate_to``, ``rotate``,
``go_home`` and a non-zero ``set_velocity``) raise :class:`BackendError` unless
the robot is in a state that may move (``IN_CONTROL``). Every node that drives the robot (the
Slamware topics, ``/cmd_vel``, ``/move_base``, ``/navigation``, patrols, graph navigation, the
``/cmd_string`` shell) therefore sees the same refusal with the same text, without knowing
about locomotion at all. Stopping (``cancel_action``, a zero ``set_velocity``) is always
allowed.

States follow the seed's locomotion state values (0-9). The simulated robot starts in
``IN_CONTROL``; ``sit_down`` stops any motion and goes to ``SITDOWN_MODE``; ``stand_up`` goes to
``STANDING_MODE`` and, after :attr:`Locomotion.stand_up_seconds`, to ``IN_CONTROL``. While
the robot is unreachable the state reads ``COMM_DISABLED``; a reboot brings it back standing.

The control mode (``set_listen``) says who may drive, reported in
``robot_state.joy_listen_type`` and enforced by the same gate:

* ``"vel_cmd/autonomy"`` (VEL_CMD, the start-up mode): the app and autonomy -- every motion
  command (goals, patrols, ``/cmd_vel``, MoveBy);
* ``"joy/gui<&>network_id"`` (JOY): the joystick -- manual commands only (``/cmd_vel``,
  ``move_by_direction``, ``move_by_theta``); autonomous motion (``move_to``, navigation,
  ``/move_base``, patrols, ``rotate``/``rotate_to``, ``go_home``) is refused, saying who has
  control and how to release it;
* ``"topic<&><CLOSE>"`` releasing the active source (NONE): nothing drives until a source is
  claimed again.

Stopping is always allowed. The bridge cannot tell which client is the joystick (the network
id is recorded and reported, not matched against connections): the mode selects the kind of
command, not the sender.
"""

from __future__ import annotations

import asyncio
import contextlib
import enum
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from .backend import BackendError, Link, MotionBackend


class LocomotionState(enum.IntEnum):
    COMM_DISABLED = 0
    COMM_ENABLED = 1
    MOTOR_READY = 2
    MOTOR_COMMUTATION = 3
    MOTOR_ENABLED = 4
    IN_TEST_MODE = 5
    STANDING_MODE = 6
    IN_CONTROL = 7
    SITDOWN_MODE = 8
    MOTOR_DISABLED = 9


class JoyListenType(enum.IntEnum):
    JOY = 0
    VEL_CMD = 1
    NONE = 2


MOTION_STATES = frozenset({LocomotionState.IN_CONTROL})
"""States in which the robot may be driven."""
MOTORS_ENABLED_STATES = frozenset({LocomotionState.MOTOR_ENABLED, LocomotionState.STANDING_MODE,
                                   LocomotionState.IN_CONTROL, LocomotionState.IN_TEST_MODE})
"""States in which the drive motors are powered (CiA402 OPERATION_ENABLED)."""
STAND_UP_SECONDS = 1.0
"""Simulated seconds the stand-up transition (STANDING_MODE → IN_CONTROL) takes."""

_WHY = {
    LocomotionState.SITDOWN_MODE: "the robot is sitting",
    LocomotionState.STANDING_MODE: "the robot is still standing up",
    LocomotionState.MOTOR_DISABLED: "the motors are disabled",
}

JOY_TOPIC = "joy/gui"
AUTONOMY_TOPIC = "vel_cmd/autonomy"
SEPARATOR = "<&>"
CLOSE = "<CLOSE>"
LISTEN_TOPICS = {JOY_TOPIC: JoyListenType.JOY, AUTONOMY_TOPIC: JoyListenType.VEL_CMD}
LISTEN_FORMATS = ('"joy/gui<&>network_id", "vel_cmd/autonomy" or "topic_name<&><CLOSE>" '
                  '(e.g. "joy/gui<&><CLOSE>")')


class ListenError(ValueError):
    """A ``set_listen`` request in none of the three formats."""


@dataclass(frozen=True, slots=True)
class ListenRequest:
    """A parsed ``set_listen`` string: claim ``topic`` (with ``network_id``) or release it."""

    topic: str
    release: bool
    network_id: str = ""


def parse_listen(data: str) -> ListenRequest:
    """Parse ``set_listen``'s ``data``; :class:`ListenError` says what is wrong."""
    text = data.strip()
    if not text:
        raise ListenError(f"empty request; expected {LISTEN_FORMATS}")
    topic, sep, arg = text.partition(SEPARATOR)
    topic, arg = topic.strip(), arg.strip()
    if topic not in LISTEN_TOPICS:
        raise ListenError(f"unknown control source {topic!r}; expected {LISTEN_FORMATS}")
    if sep and arg == CLOSE:
        return ListenRequest(topic, release=True)
    if topic == JOY_TOPIC:
        if not arg:
            raise ListenError("joy/gui needs a network id: \"joy/gui<&>network_id\"")
        return ListenRequest(topic, release=False, network_id=arg)
    if sep:
        raise ListenError(f"vel_cmd/autonomy takes no argument other than {CLOSE}")
    return ListenRequest(topic, release=False)


class ControlMode:
    """Who claims the robot (``set_listen``)."""

    def __init__(self, initial: JoyListenType = JoyListenType.VEL_CMD):
        self.listen_type = initial
        self.network_id = ""

    def check(self, manual: bool) -> None:
        """Raise :class:`BackendError` when the current source may not give this command:
        with the joystick listening only manual commands drive; with nobody listening
        nothing does (stopping is never checked)."""
        if self.listen_type == JoyListenType.NONE:
            raise BackendError(
                "motion refused: no control source is listening (set_listen released it); "
                f'claim one with "{AUTONOMY_TOPIC}" or "{JOY_TOPIC}{SEPARATOR}network_id"')
        if self.listen_type == JoyListenType.JOY and not manual:
            who = f" from {self.network_id}" if self.network_id else ""
            raise BackendError(
                f"motion refused: the joystick{who} has control (set_listen {JOY_TOPIC}); only "
                f'manual commands drive until "{JOY_TOPIC}{SEPARATOR}{CLOSE}" or '
                f'"{AUTONOMY_TOPIC}"')

    def apply(self, request: ListenRequest) -> str:
        """Apply a parsed request; the user-facing result text."""
        wanted = LISTEN_TOPICS[request.topic]
        if request.release:
            if self.listen_type != wanted:
                return f"{request.topic} was not listening; nothing to release"
            self.listen_type, self.network_id = JoyListenType.NONE, ""
            return f"released {request.topic}"
        self.listen_type, self.network_id = wanted, request.network_id
        if request.network_id:
            return f"listening to {request.topic} from {request.network_id}"
        return f"listening to {request.topic}"


class Locomotion:
    """The locomotion state machine of one robot (sit/stand, the control mode): the state is
    the robot's own, but the bridge keeps it, so it reads ``COMM_DISABLED`` while ``link``
    says the robot is unreachable. ``motion`` is the robot's ungated motion (sitting down stops
    it)."""

    def __init__(self, link: Link, motion: MotionBackend,
                 stand_up_seconds: float = STAND_UP_SECONDS,
                 initial: LocomotionState = LocomotionState.IN_CONTROL):
        self.link = link
        self.motion = motion
        self.stand_up_seconds = stand_up_seconds
        self._initial = initial
        self._state = initial
        self._transition: asyncio.Task | None = None
        self.control = ControlMode()

    @property
    def state(self) -> LocomotionState:
        """The locomotion state; ``COMM_DISABLED`` while the robot is unreachable."""
        return self._state if self.link.connected else LocomotionState.COMM_DISABLED

    @property
    def motion_allowed(self) -> bool:
        return self.state in MOTION_STATES

    @property
    def motors_enabled(self) -> bool:
        return self.state in MOTORS_ENABLED_STATES

    def _cancel_transition(self) -> None:
        task, self._transition = self._transition, None
        if task is not None and task is not asyncio.current_task():
            task.cancel()

    async def sit_down(self) -> None:
        """Stop whatever the robot is doing and sit down (motion refused from now on)."""
        self._cancel_transition()
        self._state = LocomotionState.SITDOWN_MODE
        if self.link.connected:
            with contextlib.suppress(BackendError):
                await self.motion.cancel_action()  # also ends /cmd_vel velocity control

    async def stand_up(self) -> None:
        """Start standing up: STANDING_MODE now, IN_CONTROL after the transition."""
        if self._state == LocomotionState.IN_CONTROL or self._transition is not None:
            return
        self._state = LocomotionState.STANDING_MODE

        async def finish() -> None:
            await asyncio.sleep(self.stand_up_seconds)
            if self._state == LocomotionState.STANDING_MODE:
                self._state = LocomotionState.IN_CONTROL
            self._transition = None

        self._transition = asyncio.get_running_loop().create_task(finish(), name="stand-up")

    def check_motion(self, manual: bool = False) -> None:
        """Refuse motion the locomotion state or the control mode does not allow; ``manual``
        is teleoperation (velocity and MoveBy commands) as opposed to autonomous motion."""
        if not self.link.connected:
            return  # the robot's motion says "not connected" itself
        state = self._state
        if state not in MOTION_STATES:
            why = _WHY.get(state, "the robot is not in control")
            raise BackendError(f"motion refused: {why} (locomotion state {state.name})")
        self.control.check(manual)

    def restarted(self) -> None:
        """The robot rebooted: it comes back as freshly started."""
        self._cancel_transition()
        self._state = self._initial


def _gated(name: str, manual: bool = False) -> Callable[..., Awaitable[Any]]:
    """A motion command that moves the robot: checked by the locomotion first."""
    async def command(self: GatedMotion, *args: Any, **kwargs: Any) -> Any:
        self.locomotion.check_motion(manual)
        return await getattr(self.inner, name)(*args, **kwargs)
    command.__name__ = name
    return command


def _through(name: str) -> Callable[..., Awaitable[Any]]:
    """A motion request that never moves the robot: passed straight through."""
    async def request(self: GatedMotion, *args: Any, **kwargs: Any) -> Any:
        return await getattr(self.inner, name)(*args, **kwargs)
    request.__name__ = name
    return request


class GatedMotion(MotionBackend):
    """A robot's motion behind its :class:`Locomotion`: commands that move the robot are
    checked first (see the module text); stopping and reading actions pass straight through.
    Every method of the protocol is named here once, gated or not (an abstract one left out
    keeps the class abstract; ``tests/robot/test_composed.py`` fails on any left out)."""

    def __init__(self, inner: MotionBackend, locomotion: Locomotion):
        self.inner = inner
        self.locomotion = locomotion

    move_to = _gated("move_to")
    rotate_to = _gated("rotate_to")
    rotate = _gated("rotate")
    go_home = _gated("go_home")
    move_by_direction = _gated("move_by_direction", manual=True)
    move_by_theta = _gated("move_by_theta", manual=True)

    async def set_velocity(self, linear: float, angular: float) -> None:
        if linear != 0.0 or angular != 0.0:  # a stop is always allowed
            self.locomotion.check_motion(manual=True)
        await self.inner.set_velocity(linear, angular)

    compute_path = _through("compute_path")
    cancel_action = _through("cancel_action")
    get_current_action = _through("get_current_action")
    get_action = _through("get_action")
    get_remaining_path = _through("get_remaining_path")
    get_remaining_milestones = _through("get_remaining_milestones")

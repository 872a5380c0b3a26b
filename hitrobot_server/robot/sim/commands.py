"""The simulated robot's actions (:class:`Actions`, a part of :class:`~.simulator.Simulator`):
the current one and the recent ones by id, and the commands that start, follow and stop
them."""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Sequence
from typing import TYPE_CHECKING

from ..model import (
    ActionDirection,
    ActionInfo,
    ActionResult,
    LocalizationMovement,
    MoveOptionFlag,
    MoveOptions,
    Point2D,
    Rect,
)
from .actions import (
    Action,
    GoHomeAction,
    MoveByAction,
    MoveToAction,
    RecoverLocalizationAction,
    RotateAction,
    VelocityControlAction,
)
from .checks import checked_duration, checked_point

if TYPE_CHECKING:
    from .context import ActionContext

ACTION_HISTORY = 20
"""Finished actions stay queryable by id for this many actions, as on the REST API."""


class Actions:
    """The current action (one at a time: a new one supersedes it), the last
    :data:`ACTION_HISTORY` actions by id, and the motion requests that start them; the
    simulator ticks :attr:`current`. Bad arguments raise ``ValueError``. ``context`` is what a
    running action sees (its clock too); ``velocity_timeout`` the ``/cmd_vel`` dead-man time."""

    def __init__(self, context: ActionContext, velocity_timeout: float) -> None:
        self.current: Action | None = None
        self._history: OrderedDict[int, Action] = OrderedDict()
        self._next_action_id = 1
        self._context = context
        self._velocity_timeout = velocity_timeout

    def running(self) -> Action | None:
        """The current action unless it has finished."""
        current = self.current
        return None if current is None or current.done else current

    def _new_id(self) -> int:
        action_id = self._next_action_id
        self._next_action_id += 1
        return action_id

    def _start(self, action: Action) -> ActionInfo:
        current = self.current
        if current is not None and not current.done:
            current.finish(ActionResult.ABORTED, "superseded by a new action")
        self.current = action
        self._history[action.action_id] = action
        while len(self._history) > ACTION_HISTORY:
            self._history.popitem(last=False)
        return action.info()

    def abort(self, reason: str) -> None:
        """End the running action, if any, as ``ABORTED`` with ``reason``."""
        current = self.running()
        if current is not None:
            current.finish(ActionResult.ABORTED, reason)

    def move_to(
        self, targets: Sequence[Point2D], options: MoveOptions | None = None, yaw: float = 0.0
    ) -> ActionInfo:
        options = options or MoveOptions()
        if not targets:
            raise ValueError("move_to needs at least one target")
        for t in targets:
            checked_point(t)
        if not math.isfinite(yaw):
            raise ValueError("yaw must be finite")
        current = self.current
        if (
            options.flags & MoveOptionFlag.APPENDING
            and isinstance(current, MoveToAction)
            and not current.done
        ):
            current.append(targets, options, yaw)
            return current.info()
        return self._start(MoveToAction(self._new_id(), targets, options, yaw))

    def move_by_direction(
        self, direction: ActionDirection, options: MoveOptions | None = None, duration: float = 0.5
    ) -> ActionInfo:
        direction = ActionDirection(direction)
        return self._start(
            MoveByAction(self._new_id(), options or MoveOptions(),
                         checked_duration(duration), direction=direction)
        )

    def move_by_theta(
        self, theta: float, options: MoveOptions | None = None, duration: float = 0.5
    ) -> ActionInfo:
        if not math.isfinite(theta):
            raise ValueError("theta must be finite")
        return self._start(
            MoveByAction(self._new_id(), options or MoveOptions(),
                         checked_duration(duration), theta=theta)
        )

    def rotate_to(self, yaw: float, options: MoveOptions | None = None) -> ActionInfo:
        if not math.isfinite(yaw):
            raise ValueError("yaw must be finite")
        return self._start(
            RotateAction(self._new_id(), yaw, options or MoveOptions(), True))

    def rotate(self, angle: float, options: MoveOptions | None = None) -> ActionInfo:
        if not math.isfinite(angle):
            raise ValueError("angle must be finite")
        return self._start(
            RotateAction(self._new_id(), angle, options or MoveOptions(), False))

    def go_home(self, options: MoveOptions | None = None) -> ActionInfo:
        return self._start(GoHomeAction(self._new_id(), options or MoveOptions()))

    def recover_localization(
        self,
        area: Rect | None = None,
        max_time_ms: int | None = None,
        movement: LocalizationMovement | None = None,
    ) -> ActionInfo:
        if max_time_ms is not None and max_time_ms <= 0:
            raise ValueError("max_time_ms must be positive")
        max_time = None if max_time_ms is None else max_time_ms / 1000.0
        movement = LocalizationMovement.NO_MOVE if movement is None else movement
        return self._start(
            RecoverLocalizationAction(self._new_id(), area, max_time, movement))

    def set_velocity(self, linear: float, angular: float) -> None:
        if not (math.isfinite(linear) and math.isfinite(angular)):
            raise ValueError("velocities must be finite")
        current = self.current
        if not isinstance(current, VelocityControlAction) or current.done:
            current = VelocityControlAction(self._new_id(), self._velocity_timeout)
            self._start(current)
        current.command(linear, angular, self._context.time)

    def cancel_action(self) -> ActionInfo | None:
        current = self.running()
        if current is None:
            return None
        current.finish(ActionResult.ABORTED, "cancelled")
        return current.info()

    def current_action(self) -> ActionInfo | None:
        current = self.running()
        return None if current is None else current.info()

    def action(self, action_id: int) -> ActionInfo | None:
        found = self._history.get(action_id)
        return None if found is None else found.info()

    def remaining_path(self) -> list[Point2D]:
        current = self.running()
        return [] if current is None else current.remaining_path(self._context)

    def remaining_milestones(self) -> list[Point2D]:
        current = self.running()
        return [] if current is None else current.milestones()

"""Motion actions: one class per Slamware action, each a small state machine ticked by the
simulator.

An action is born ``NEW_BORN``, becomes ``WORKING`` on its first tick and ends ``DONE`` with a
result of ``SUCCESS``, ``FAILED`` (with a reason) or ``ABORTED`` (cancelled or replaced), as the
REST API reports them. ``tick`` returns the velocity command for the tick.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence

from ..backend import ACTION_PREFIX
from ..model import (
    ActionDirection,
    ActionInfo,
    ActionResult,
    ActionStatus,
    LocalizationMovement,
    MoveOptionFlag,
    MoveOptions,
    Point2D,
    Pose2D,
    Rect,
)
from ..planning.geometry import compose, inverse, wrap_angle
from ..planning.matching import RelocalizationSearch
from .context import ActionContext
from .follower import YAW_TOLERANCE, FollowerConfig, turn_command
from .navigation import Navigator, speed_ratio

DOCK_APPROACH = 0.6
"""Distance (m) in front of the dock where the robot lines up before reversing onto it."""
DOCK_SPEED = 0.15
RELOCALIZE_TURN_SPEED = 0.5


class Action(ABC):
    """Bookkeeping shared by all actions; subclasses implement :meth:`_run`."""

    name = "Action"

    def __init__(self, action_id: int) -> None:
        self.action_id = action_id
        self.status = ActionStatus.NEW_BORN
        self.result = ActionResult.SUCCESS
        self.reason = ""
        self.stage = "INITIALIZING"

    @property
    def done(self) -> bool:
        return self.status == ActionStatus.DONE

    def info(self) -> ActionInfo:
        return ActionInfo(
            self.action_id,
            ACTION_PREFIX + self.name,
            self.stage,
            self.status,
            self.result,
            self.reason,
        )

    def tick(self, ctx: ActionContext) -> tuple[float, float]:
        if self.done:
            return 0.0, 0.0
        self.status = ActionStatus.WORKING
        return self._run(ctx)

    def finish(self, result: ActionResult, reason: str = "") -> None:
        if not self.done:
            self.status = ActionStatus.DONE
            self.result = result
            self.reason = reason

    def on_collision(self, bearing: float) -> None:  # noqa: B027 - optional hook, default no-op
        """The bumper fired during this action, at ``bearing`` off the robot's heading."""

    def remaining_path(self, ctx: ActionContext) -> list[Point2D]:
        return []

    def milestones(self) -> list[Point2D]:
        return []

    @abstractmethod
    def _run(self, ctx: ActionContext) -> tuple[float, float]:
        """One tick of the action's own logic; returns (linear, angular)."""


class MoveToAction(Action):
    """Navigate through one or more targets (``MoveToAction`` / ``SeriesMoveToAction``)."""

    def __init__(
        self, action_id: int, targets: Sequence[Point2D], options: MoveOptions, yaw: float
    ) -> None:
        super().__init__(action_id)
        self.name = "MoveToAction" if len(targets) == 1 else "SeriesMoveToAction"
        self._nav = Navigator(targets, options, yaw)

    def append(self, targets: Sequence[Point2D], options: MoveOptions, yaw: float) -> None:
        self.name = "SeriesMoveToAction"
        self._nav.append(targets, options, yaw)

    def on_collision(self, bearing: float) -> None:  # noqa: B027 - optional hook, default no-op
        self._nav.on_collision(bearing)

    def remaining_path(self, ctx: ActionContext) -> list[Point2D]:
        return self._nav.remaining_path(ctx)

    def milestones(self) -> list[Point2D]:
        return self._nav.milestones()

    def _run(self, ctx: ActionContext) -> tuple[float, float]:
        command = self._nav.tick(ctx)
        self.stage = self._nav.stage
        if self._nav.failure is not None:
            self.finish(ActionResult.FAILED, self._nav.failure)
            return 0.0, 0.0
        if self._nav.done:
            self.finish(ActionResult.SUCCESS)
        return command


class GoHomeAction(Action):
    """Drive to a point in front of the dock, line up, reverse onto the contacts."""

    name = "GoHomeAction"

    def __init__(self, action_id: int, options: MoveOptions) -> None:
        super().__init__(action_id)
        self._options = options
        self._nav: Navigator | None = None
        self._home: Pose2D | None = None
        self._docking = False

    def on_collision(self, bearing: float) -> None:  # noqa: B027 - optional hook, default no-op
        if self._nav is not None and not self._docking:
            self._nav.on_collision(bearing)

    def remaining_path(self, ctx: ActionContext) -> list[Point2D]:
        if self._nav is None or self._docking:
            return []
        return [*self._nav.remaining_path(ctx), *self.milestones()]

    def milestones(self) -> list[Point2D]:
        home = self._home
        return [] if home is None or self.done else [Point2D(home.x, home.y)]

    def _run(self, ctx: ActionContext) -> tuple[float, float]:
        if self._home is None:
            if ctx.docked:
                self.finish(ActionResult.SUCCESS)
                return 0.0, 0.0
            if ctx.home_pose is None:
                self.finish(ActionResult.FAILED, "no home dock in the map")
                return 0.0, 0.0
            self._home = home = ctx.home_pose
            approach = compose(home, Pose2D(DOCK_APPROACH, 0.0, 0.0))
            options = MoveOptions(
                flags=MoveOptionFlag.PRECISE | MoveOptionFlag.WITH_YAW,
                speed_ratio=self._options.speed_ratio,
                mode=self._options.mode,
                fail_retry_count=self._options.fail_retry_count,
            )
            self._nav = Navigator([Point2D(approach.x, approach.y)], options, home.yaw)
        if not self._docking:
            command = self._nav.tick(ctx)
            self.stage = "GOING_HOME"
            if self._nav.failure is not None:
                self.finish(ActionResult.FAILED, self._nav.failure)
                return 0.0, 0.0
            if not self._nav.done:
                return command
            self._docking = True
        self.stage = "DOCKING"
        return self._reverse_onto_dock(ctx)

    def _reverse_onto_dock(self, ctx: ActionContext) -> tuple[float, float]:
        """Back straight onto the dock, steering the tail towards the dock line."""
        rel = compose(inverse(self._home), ctx.pose)
        if rel.x <= 0.005:
            if ctx.docked:
                self.finish(ActionResult.SUCCESS)
            else:
                self.finish(ActionResult.FAILED, "docking failed: no charging contact")
            return 0.0, 0.0
        accel = ctx.drive.linear_accel
        speed = max(0.03, min(DOCK_SPEED, math.sqrt(2.0 * 0.6 * accel * rel.x)))
        heading = max(-0.3, min(0.3, 3.0 * rel.y))
        return -speed, 3.0 * wrap_angle(heading - rel.yaw)


class MoveByAction(Action):
    """Open-loop manual motion for a short duration, without obstacle avoidance."""

    name = "MoveByAction"

    def __init__(
        self,
        action_id: int,
        options: MoveOptions,
        duration: float,
        direction: ActionDirection | None = None,
        theta: float = 0.0,
    ) -> None:
        super().__init__(action_id)
        self._ratio = speed_ratio(options)
        self._duration = duration
        self._direction = direction
        self._theta = wrap_angle(theta)
        self._end: float | None = None

    def _run(self, ctx: ActionContext) -> tuple[float, float]:
        if self._end is None:
            self._end = ctx.time + self._duration
        if ctx.time >= self._end:
            self.finish(ActionResult.SUCCESS)
            return 0.0, 0.0
        self.stage = "MOVING"
        linear = ctx.drive.max_linear * self._ratio
        angular = ctx.drive.max_angular * self._ratio
        match self._direction:
            case ActionDirection.FORWARD:
                return linear, 0.0
            case ActionDirection.BACKWARD:
                return -linear, 0.0
            case ActionDirection.TURNLEFT:
                return 0.0, angular
            case ActionDirection.TURNRIGHT:
                return 0.0, -angular
        # Heading mode: drive forward while turning towards theta (off the nose).
        forward = linear * max(0.0, math.cos(self._theta))
        return forward, max(-angular, min(angular, 2.0 * self._theta))


class RotateAction(Action):
    """Turn in place to an absolute heading (``RotateToAction``) or by an angle
    (``RotateAction``; more than a full turn allowed)."""

    def __init__(self, action_id: int, angle: float, options: MoveOptions, absolute: bool) -> None:
        super().__init__(action_id)
        self.name = "RotateToAction" if absolute else "RotateAction"
        self._angle = angle
        self._absolute = absolute
        self._ratio = speed_ratio(options)
        self._turned = 0.0
        self._last_yaw: float | None = None

    def _run(self, ctx: ActionContext) -> tuple[float, float]:
        yaw = ctx.pose.yaw
        if self._last_yaw is not None:
            self._turned += wrap_angle(yaw - self._last_yaw)
        self._last_yaw = yaw
        error = wrap_angle(self._angle - yaw) if self._absolute else self._angle - self._turned
        if abs(error) < YAW_TOLERANCE:
            self.finish(ActionResult.SUCCESS)
            return 0.0, 0.0
        self.stage = "ROTATING"
        drive = ctx.drive
        return 0.0, turn_command(
            error, drive.max_angular * self._ratio, drive.angular_accel, FollowerConfig()
        )


class RecoverLocalizationAction(Action):
    """Search the map for the current scan; turn in place meanwhile if movement allows."""

    name = "RecoverLocalizationAction"

    def __init__(
        self,
        action_id: int,
        area: Rect | None,
        max_time: float | None,
        movement: LocalizationMovement,
    ) -> None:
        super().__init__(action_id)
        self._area = area
        self._max_time = max_time
        self._turn = movement != LocalizationMovement.NO_MOVE
        self._search: RelocalizationSearch | None = None
        self._captured: Pose2D | None = None
        self._deadline = math.inf

    def _run(self, ctx: ActionContext) -> tuple[float, float]:
        if self._search is None:
            self._search = ctx.start_relocalization(self._area)
            self._captured = ctx.scan_odometry
            if self._max_time is not None:
                self._deadline = ctx.time + self._max_time
        self.stage = "RELOCALIZING"
        if not self._search.advance(ctx.match_budget):
            if ctx.time >= self._deadline:
                ctx.report_relocalization(False)
                self.finish(ActionResult.FAILED, "relocalization timed out")
                return 0.0, 0.0
            return 0.0, RELOCALIZE_TURN_SPEED if self._turn else 0.0
        match = self._search.pose
        if match is None:
            ctx.report_relocalization(False)
            self.finish(ActionResult.FAILED, "relocalization failed: no matching pose")
        else:
            ctx.relocalize(match, self._captured)
            ctx.report_relocalization(True)
            self.finish(ActionResult.SUCCESS)
        return 0.0, 0.0


class VelocityControlAction(Action):
    """``/cmd_vel`` driving with a dead-man timeout: stops and finishes when commands lapse."""

    name = "VelocityControlAction"

    def __init__(self, action_id: int, timeout: float) -> None:
        super().__init__(action_id)
        self._timeout = timeout
        self._command = (0.0, 0.0)
        self._stamp = -math.inf

    def command(self, linear: float, angular: float, now: float) -> None:
        self._command = (linear, angular)
        self._stamp = now

    def _run(self, ctx: ActionContext) -> tuple[float, float]:
        if ctx.time - self._stamp > self._timeout:
            self.finish(ActionResult.SUCCESS)
            return 0.0, 0.0
        self.stage = "MOVING"
        return self._command

"""Goal-to-goal navigation: plan each leg, follow it, replan when the way is blocked.

This is where the Slamware move flags take effect:

* ``PRECISE`` tightens the arrival tolerance to 0.05 m (default 0.15 m; ``acceptable_precision``
  overrides both);
* ``WITH_YAW`` turns to the requested yaw after the last target (within 0.05 rad);
* ``NO_SMOOTH`` keeps the raw grid path;
* a target the robot cannot stand on (inside an inflated obstacle) is replaced by the nearest
  spot it can park on, clear of the inflation; the robot drives there and the move then
  **fails** ("the target ... is inside an obstacle: stopped at the nearest free spot X m
  away") unless that
  spot is within the arrival tolerance of the target: a move is a success only when the robot
  stands within tolerance of every target;
* ``RETURN_UNREACHABLE_DIRECTLY`` fails at once, without moving, when a target cannot be stood
  on;
* ``KEY_POINTS`` / mode 1 plan strictly along virtual tracks; ``KEY_POINTS_WITH_OA`` / mode 2
  prefer tracks but may leave them;
* ``planning_area`` (not a flag) confines every leg's search to that rectangle;
* ``APPENDING`` is handled by the caller (:meth:`Navigator.append`); ``MILESTONE`` is deprecated
  in the SDK and ignored.

While following, the path ahead is re-checked against the latest costmap every half second
(the lidar keeps updating the map), and a collision forces a replan. Each replan spends one
retry; ``fail_retry_count`` (default 5) bounds them.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

import numpy as np

from ..model import MoveOptionFlag, MoveOptions, Point2D
from ..planning.costmap import densify
from ..planning.planner import PathSearch
from ..planning.search import DEFAULT_TOLERANCE, arrival_tolerance, path_search
from .context import ActionContext
from .follower import PathFollower

REPLAN_PERIOD = 0.5
"""Seconds between checks of the path ahead."""
CHECK_FROM = 0.3
CHECK_TO = 2.0
"""The stretch of path ahead (m) that must stay free; the first bit is skipped because the robot
may legitimately start inside an inflated zone."""
STUCK_TIMEOUT = 30.0
"""Seconds without getting 0.1 m closer to the current target before giving up."""
DEFAULT_RETRIES = 5
ARRIVAL_SLACK = 0.02
"""Metres of localization jitter allowed on top of the tolerance when checking arrival."""
BACK_OFF_TIME = 0.5
BACK_OFF_SPEED = 0.1
"""After a collision the robot eases away from the contact (about 4 cm) before replanning, so
the new plan does not start pressed against the obstacle."""


def speed_ratio(options: MoveOptions) -> float:
    """``speed_ratio`` clamped to the 0.1-1.0 range the chassis honours."""
    return 1.0 if options.speed_ratio is None else min(1.0, max(0.1, options.speed_ratio))


class Navigator:
    """Drives through a queue of targets; check :attr:`done` and :attr:`failure`."""

    def __init__(self, targets: Sequence[Point2D], options: MoveOptions, yaw: float) -> None:
        self._targets: deque[Point2D] = deque(targets)
        self._options = options
        self._yaw = yaw
        self._search: PathSearch | None = None
        self._follower: PathFollower | None = None
        self._retries = 0
        self._next_check = 0.0
        self._best_distance = math.inf
        self._best_time = 0.0
        self._back_off: tuple[float, float] | None = None
        self._tolerance = DEFAULT_TOLERANCE
        self.stage = "PLANNING"
        self.done = not self._targets
        self.failure: str | None = None

    def append(self, targets: Sequence[Point2D], options: MoveOptions, yaw: float) -> None:
        """Queue more targets; the new options and yaw apply from now on."""
        if self._follower is not None and len(self._targets) == 1:
            self._follower = None  # the current leg no longer ends with the final turn
        self._targets.extend(targets)
        self._options = options
        self._yaw = yaw

    def milestones(self) -> list[Point2D]:
        return list(self._targets)

    def remaining_path(self, ctx: ActionContext) -> list[Point2D]:
        if self._follower is None:
            return []
        return [Point2D(x, y) for x, y in self._follower.remaining_path(ctx.pose)]

    def on_collision(self, bearing: float) -> None:
        """The bumper fired at ``bearing``: back away, then replan (or give up)."""
        self._replan("blocked by an obstacle")
        speed = -BACK_OFF_SPEED if abs(bearing) < math.pi / 2 else BACK_OFF_SPEED
        self._back_off = (speed, math.inf)

    def tick(self, ctx: ActionContext) -> tuple[float, float]:
        """Velocity command for this tick."""
        if self.done or self.failure is not None:
            return 0.0, 0.0
        if self._back_off is not None:
            speed, until = self._back_off
            if until == math.inf:
                until = ctx.time + BACK_OFF_TIME
                self._back_off = (speed, until)
            if ctx.time < until:
                self.stage = "RECOVERING"
                return speed, 0.0
            self._back_off = None
        if self._follower is None:
            search = self._search or self._start_search(ctx)
            result = search.advance(ctx.plan_budget)
            if result is None:
                self.stage = "PLANNING"
                return 0.0, 0.0
            self._search = None
            if not result.ok:
                self.failure = result.reason
                return 0.0, 0.0
            self._start_leg(ctx, result.path)
        follower = self._follower
        if ctx.time >= self._next_check:
            self._next_check = ctx.time + REPLAN_PERIOD
            if self._blocked_ahead(ctx, follower):
                self._replan("path blocked")
                return 0.0, 0.0
            if self._stuck(ctx, follower):
                self.failure = "robot is stuck"
                return 0.0, 0.0
        linear, angular = follower.command(ctx.pose)
        self.stage = "ROTATING" if follower.arrived else "GOING_TO_TARGET"
        if follower.done:
            target = self._targets[0]
            off = math.hypot(target.x - ctx.pose.x, target.y - ctx.pose.y)
            if off > self._tolerance + ARRIVAL_SLACK:
                self.failure = (f"the target ({target.x:.2f}, {target.y:.2f}) is inside an "
                                f"obstacle: stopped at the nearest free spot {off:.2f} m away "
                                f"(tolerance {self._tolerance:.2f} m)")
                return 0.0, 0.0
            self._targets.popleft()
            self._follower = None
            self.done = not self._targets
        return linear, angular

    def _start_search(self, ctx: ActionContext) -> PathSearch:
        target = self._targets[0]
        self._search = search = path_search(
            ctx.costmap(), (ctx.pose.x, ctx.pose.y), (target.x, target.y), self._options)
        return search

    def _start_leg(self, ctx: ActionContext, path: Sequence[tuple[float, float]]) -> None:
        options = self._options
        last = len(self._targets) == 1
        tolerance = arrival_tolerance(options)
        with_yaw = last and bool(options.flags & MoveOptionFlag.WITH_YAW)
        self._tolerance = tolerance
        self._follower = PathFollower(
            path,
            ctx.drive,
            speed_ratio=speed_ratio(options),
            tolerance=tolerance,
            final_yaw=self._yaw if with_yaw else None,
        )
        self._next_check = ctx.time + REPLAN_PERIOD
        self._best_distance = math.inf
        self._best_time = ctx.time

    def _replan(self, reason: str) -> None:
        limit = self._options.fail_retry_count
        self._retries += 1
        if self._retries > (DEFAULT_RETRIES if limit is None else limit):
            self.failure = reason
        self._follower = None
        self._search = None

    def _blocked_ahead(self, ctx: ActionContext, follower: PathFollower) -> bool:
        path = follower.remaining_path(ctx.pose)
        if len(path) < 2:
            return False
        samples = densify(np.asarray(path), ctx.costmap().spec.resolution * 0.5)
        along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(samples, axis=0).T))))
        window = samples[(along >= CHECK_FROM) & (along <= CHECK_TO)]
        return len(window) > 0 and bool(ctx.costmap().lethal_at(window).any())

    def _stuck(self, ctx: ActionContext, follower: PathFollower) -> bool:
        if follower.arrived:
            return False
        gx, gy = follower.goal
        distance = math.hypot(gx - ctx.pose.x, gy - ctx.pose.y)
        if distance < self._best_distance - 0.1:
            self._best_distance = distance
            self._best_time = ctx.time
        return ctx.time - self._best_time > STUCK_TIMEOUT

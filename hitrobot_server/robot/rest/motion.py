"""``RestMotion``: starting, following and stopping actions over the Slamware REST API.

Where REST and :class:`~hitrobot_server.robot.backend.MotionBackend` differ:

* ``set_velocity`` is emulated with short ``MoveByAction`` actions (direction or heading, with a
  speed ratio);
* ``APPENDING`` is emulated by re-sending the remaining milestones plus the new targets;
* ``MoveOptions.planning_area`` has no REST form and is ignored by the robot;
* ``compute_path`` (plan without moving) has no REST form: the server plans on the robot's map
  itself; ``RETURN_UNREACHABLE_DIRECTLY`` has none either: the target is checked on that map
  before the move is sent;
* a move the robot reports as a success but that ended out of tolerance of its target is
  reported as FAILED (``get_action``).
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import math
from collections.abc import Sequence

import numpy as np

from ..backend import BackendError, MotionBackend
from ..model import (
    ActionDirection,
    ActionInfo,
    ActionResult,
    MoveOptionFlag,
    MoveOptions,
    Point2D,
    Pose2D,
    Rect,
)
from ..planning.search import arrival_tolerance, check_poses, searched_path
from . import paths, shapes
from .link import RestLink, failed
from .localization import RestLocalization
from .maps import RestMaps

log = logging.getLogger(__name__)

MANUAL_HOLD = 0.25
"""Seconds one ``set_velocity`` keeps the robot moving (the MoveBy ``duration``): short, so the
robot stops soon after the last command (``/cmd_vel`` publishers send at 10 Hz or more)."""
MANUAL_LINEAR = 0.7
MANUAL_ANGULAR = 1.8
"""Nominal full manual speeds (m/s, rad/s): a twist's speed ratio is measured against them."""
MOVE_ACTIONS = (shapes.MOVE_TO, shapes.SERIES_MOVE_TO)
ACTION_HISTORY = 20
"""Moves whose targets are remembered for the arrival check (the robot keeps 20 actions)."""
ARRIVAL_SLACK = 0.05
"""Metres of localization jitter allowed beyond a move's tolerance before its success is
called a failure."""


class RestMotion(MotionBackend):
    """Actions through ``POST actions``; the pose (for the arrival check) and the map (for
    planning) come from the robot's other capabilities."""

    def __init__(self, link: RestLink, localization: RestLocalization, maps: RestMaps) -> None:
        self._link = link
        self._localization = localization
        self._maps = maps
        self._manual: tuple[int, tuple, float] | None = None
        self._moves: dict[int, tuple[Point2D, float] | ActionInfo] = {}  # target or verdict

    async def move_to(
        self,
        targets: Sequence[Point2D],
        options: MoveOptions | None = None,
        yaw: float = 0.0,
    ) -> ActionInfo:
        options = options or MoveOptions()
        targets = list(targets)
        if not targets:
            raise BackendError("move_to needs at least one target")
        for t in targets:
            if not (math.isfinite(t.x) and math.isfinite(t.y)):
                raise BackendError("move_to targets must be finite")
        dropped = options.flags & shapes.DROPPED_FLAGS
        if dropped:
            log.debug("move flags %s have no REST form; not sent", dropped)
        if options.flags & MoveOptionFlag.RETURN_UNREACHABLE_DIRECTLY:
            await self._check_targets(targets)
        if options.flags & MoveOptionFlag.APPENDING:
            current = await self.get_current_action()
            if current is not None and current.action_name in MOVE_ACTIONS:
                targets = [*await self.get_remaining_milestones(), *targets]
        info = await self._link.start_action(shapes.move_to_request(targets, options, yaw))
        self._moves[info.action_id] = (targets[-1], arrival_tolerance(options))
        while len(self._moves) > ACTION_HISTORY:
            self._moves.pop(next(iter(self._moves)))
        return info

    async def compute_path(
        self, start: Pose2D | None, goal: Pose2D, options: MoveOptions | None = None
    ) -> list[Point2D]:
        """REST has no planning without moving, but the server has the robot's map: it plans
        itself with the planner a simulated move uses
        (:func:`~..planning.search.path_search`) on a costmap of the robot's explore map,
        virtual walls and tracks and the blocked areas we sent (the robot's own planner and
        footprint may differ)."""
        options = options or MoveOptions()
        check_poses(start, goal)
        origin = await self._localization.get_pose() if start is None else start
        costmap = await self._maps.costmap()
        return await searched_path(costmap, origin, goal, options, self._link.require_connection)

    async def _check_targets(self, targets: Sequence[Point2D]) -> None:
        """``RETURN_UNREACHABLE_DIRECTLY`` has no REST form: refuse here a target the robot
        cannot stand on (lethal on our costmap of its map), as the flag asks."""
        for t in targets:
            costmap = await self._maps.costmap(Rect(t.x - 1.0, t.y - 1.0, 2.0, 2.0))
            if costmap.lethal_at(np.array([[t.x, t.y]])).any():
                raise BackendError(f"target ({t.x:.2f}, {t.y:.2f}) is occupied or unreachable "
                                   "(RETURN_UNREACHABLE_DIRECTLY)")

    async def move_by_direction(
        self,
        direction: ActionDirection,
        options: MoveOptions | None = None,
        duration: float = 0.5,
    ) -> ActionInfo:
        _positive_duration(duration)
        try:
            direction = ActionDirection(direction)
        except ValueError:
            raise BackendError(f"unknown direction {direction!r}") from None
        return await self._link.start_action(
            shapes.move_by_request(direction, None, duration, options))

    async def move_by_theta(
        self, theta: float, options: MoveOptions | None = None, duration: float = 0.5
    ) -> ActionInfo:
        _positive_duration(duration)
        if not math.isfinite(theta):
            raise BackendError("theta must be finite")
        return await self._link.start_action(
            shapes.move_by_request(None, theta, duration, options))

    async def rotate_to(self, yaw: float, options: MoveOptions | None = None) -> ActionInfo:
        if not math.isfinite(yaw):
            raise BackendError("yaw must be finite")
        return await self._link.start_action(shapes.rotate_request(yaw, True, options))

    async def rotate(self, angle: float, options: MoveOptions | None = None) -> ActionInfo:
        if not math.isfinite(angle):
            raise BackendError("angle must be finite")
        return await self._link.start_action(shapes.rotate_request(angle, False, options))

    async def go_home(self, options: MoveOptions | None = None) -> ActionInfo:
        return await self._link.start_action(shapes.go_home_request(options))

    async def cancel_action(self) -> ActionInfo | None:
        current = await self.get_current_action()
        if current is None:
            return None
        reply = await self._link.request("DELETE", paths.CURRENT_ACTION,
                                         timeout=self._link.control_timeout)
        if not reply.ok and reply.status != 404:  # 404: it finished meanwhile
            raise failed("DELETE", paths.CURRENT_ACTION, reply)
        after = await self.get_action(current.action_id)
        if after is None:
            return current
        # a finished action reads back as a gravestone: keep the name and stage we know
        return dataclasses.replace(after, action_name=after.action_name or current.action_name,
                                   stage=after.stage or current.stage)

    async def get_current_action(self) -> ActionInfo | None:
        action = await self._link.get(paths.CURRENT_ACTION, shapes.action_from, missing_ok=True)
        return None if action is None or action.done else action

    async def get_action(self, action_id: int) -> ActionInfo | None:
        """The action; a move we started that the robot calls a success but that ended
        farther from its target than the tolerance (plus :data:`ARRIVAL_SLACK`) reads as
        FAILED with the distance, so no interface reports an arrival that did not happen."""
        action = await self._link.get(f"{paths.ACTIONS}/{int(action_id)}", shapes.action_from,
                                      missing_ok=True)
        move = self._moves.get(int(action_id))
        if action is None or move is None or not action.succeeded:
            return action
        if isinstance(move, ActionInfo):  # judged when it finished
            return move
        target, tolerance = move
        pose = await self._localization.get_pose()
        off = math.hypot(pose.x - target.x, pose.y - target.y)
        if off > tolerance + ARRIVAL_SLACK:
            action = dataclasses.replace(action, result=ActionResult.FAILED, reason=(
                f"target unreachable: the robot stopped {off:.2f} m from ({target.x:.2f}, "
                f"{target.y:.2f}) (tolerance {tolerance:.2f} m)"))
        self._moves[int(action_id)] = action
        return action

    async def get_remaining_path(self) -> list[Point2D]:
        return await self._link.get(paths.PATH, shapes.path_from, missing_ok=True) or []

    async def get_remaining_milestones(self) -> list[Point2D]:
        return await self._link.get(paths.MILESTONES, shapes.path_from, missing_ok=True) or []

    async def set_velocity(self, linear: float, angular: float) -> None:
        """REST has no velocity control. Emulated with short ``MoveByAction`` actions (held
        :data:`MANUAL_HOLD` s, re-sent when the command changes or half the hold passed):

        * the magnitude becomes the move's ``speed_ratio`` against the nominal manual speeds
          :data:`MANUAL_LINEAR` / :data:`MANUAL_ANGULAR` (clamped to 0.1-1, the REST range);
        * turning in place → ``TURNLEFT`` / ``TURNRIGHT``; driving forward while turning → a
          ``theta`` heading of ``angular / 2`` rad (the robot steers towards it), forward
          only → ``FORWARD``; backward → ``BACKWARD`` (REST cannot reverse along a curve, the
          turn is dropped);
        * a zero twist cancels the manual move at once, so the robot coasts at most the rest of
          one short hold after the last command."""
        if not (math.isfinite(linear) and math.isfinite(angular)):
            raise BackendError("velocities must be finite")
        loop = asyncio.get_running_loop()
        drive, turn = abs(linear) / MANUAL_LINEAR, abs(angular) / MANUAL_ANGULAR
        if drive < 2e-3 and turn < 2e-3:
            await self._stop_manual()
            return
        direction, theta, ratio = _manual_move(linear, angular, drive, turn)
        command = (direction if direction is not None else round(theta or 0.0, 2), ratio)
        now = loop.time()
        manual = self._manual
        if manual is not None and manual[1] == command and now - manual[2] < MANUAL_HOLD / 2:
            return
        info = await self._link.start_action(shapes.move_by_request(
            direction, theta, MANUAL_HOLD, MoveOptions(speed_ratio=ratio)))
        self._manual = (info.action_id, command, now)

    async def _stop_manual(self) -> None:
        """Cancel the manual move we started, if it is still the robot's current action."""
        manual, self._manual = self._manual, None
        if manual is not None:
            current = await self.get_current_action()
            if current is not None and current.action_id == manual[0]:
                await self._link.request("DELETE", paths.CURRENT_ACTION,
                                         timeout=self._link.control_timeout)


def _manual_move(linear: float, angular: float, drive: float,
                 turn: float) -> tuple[ActionDirection | None, float | None, float]:
    """The MoveBy direction or heading and the speed ratio of a non-zero twist."""
    direction: ActionDirection | None = None
    theta: float | None = None
    if drive < 2e-3 or (turn > 4 * drive):
        direction = ActionDirection.TURNLEFT if angular > 0 else ActionDirection.TURNRIGHT
        ratio = turn
    elif linear < 0:
        direction, ratio = ActionDirection.BACKWARD, drive
    elif turn < 2e-3:
        direction, ratio = ActionDirection.FORWARD, drive
    else:
        theta = max(-1.2, min(1.2, angular / 2.0))
        ratio = drive / math.cos(theta)
    return direction, theta, round(min(1.0, max(0.1, ratio)), 2)


def _positive_duration(duration: float) -> None:
    if not (math.isfinite(duration) and duration > 0.0):
        raise BackendError("duration must be positive")

"""A move's options as a search, and ``compute_path`` (plan without moving) for a backend that
has a costmap of the robot's map: the simulator plans on its own, the REST client on one it
builds of the robot's map. Both run the planner a move would use, in slices, so a long search
never stalls the loop."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

from ..backend import BackendError
from ..model import MoveOptionFlag, MoveOptions, NavigationMode, Point2D, Pose2D
from .costmap import Costmap
from .planner import PathSearch, TrackMode, run_in_slices

DEFAULT_TOLERANCE = 0.15
"""Arrival tolerance (m) without PRECISE."""
PRECISE_TOLERANCE = 0.05
"""Arrival tolerance (m) with PRECISE."""


def track_mode(options: MoveOptions) -> TrackMode:
    """Virtual-track handling requested by the flags or the REST/SDK navigation mode."""
    if (
        options.flags & MoveOptionFlag.KEY_POINTS
        or options.mode == NavigationMode.STRICT_VIRTUAL_TRACK
    ):
        return TrackMode.STRICT
    if (
        options.flags & MoveOptionFlag.KEY_POINTS_WITH_OA
        or options.mode == NavigationMode.PRIORITY_VIRTUAL_TRACK
    ):
        return TrackMode.PRIORITY
    return TrackMode.NONE


def path_search(costmap: Costmap, start: tuple[float, float], goal: tuple[float, float],
                options: MoveOptions) -> PathSearch:
    """The search a move with ``options`` plans each leg with (also ``compute_path``'s)."""
    flags = options.flags
    return PathSearch(
        costmap, start, goal,
        smooth=not flags & MoveOptionFlag.NO_SMOOTH,
        substitute_goal=not flags & MoveOptionFlag.RETURN_UNREACHABLE_DIRECTLY,
        track_mode=track_mode(options),
        bbox=options.planning_area,
    )


def arrival_tolerance(options: MoveOptions) -> float:
    """How close (m) to a target counts as there: ``acceptable_precision``, else 0.05 m with
    ``PRECISE``, else 0.15 m."""
    if options.acceptable_precision is not None:
        return options.acceptable_precision
    if options.flags & MoveOptionFlag.PRECISE:
        return PRECISE_TOLERANCE
    return DEFAULT_TOLERANCE


def check_poses(start: Pose2D | None, goal: Pose2D) -> None:
    """Refuse a request whose poses are not finite."""
    for value in (goal.x, goal.y) + (() if start is None else (start.x, start.y)):
        if not math.isfinite(value):
            raise BackendError("compute_path needs finite poses")


async def searched_path(costmap: Costmap, origin: Pose2D, goal: Pose2D, options: MoveOptions,
                        alive: Callable[[], None]) -> list[Point2D]:
    """A* from ``origin`` to ``goal`` with ``move_to``'s ``options``, run in slices of
    :data:`~.planner.PLAN_SLICE` expansions; ``alive`` raises to abandon it."""
    await asyncio.sleep(0)  # a costmap just built, its regions labelled next: two turns
    search = path_search(costmap, (origin.x, origin.y), (goal.x, goal.y), options)
    result = await run_in_slices(search, alive)
    if not result.ok:
        raise BackendError(f"no path: {result.reason}")
    return [Point2D(x, y) for x, y in result.path]

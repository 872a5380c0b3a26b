"""``compute_path`` (plan without moving) for a backend that has a costmap of the robot's map:
the simulator plans on its own, the REST client on one it builds of the robot's map. Both run
the planner a move would use, in slices, so a long search never stalls the loop."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

from .backend import BackendError
from .model import MoveOptions, Point2D, Pose2D
from .sim.costmap import Costmap
from .sim.navigation import path_search
from .sim.planner import run_in_slices


def check_poses(start: Pose2D | None, goal: Pose2D) -> None:
    """Refuse a request whose poses are not finite."""
    for value in (goal.x, goal.y) + (() if start is None else (start.x, start.y)):
        if not math.isfinite(value):
            raise BackendError("compute_path needs finite poses")


async def searched_path(costmap: Costmap, origin: Pose2D, goal: Pose2D, options: MoveOptions,
                        alive: Callable[[], None]) -> list[Point2D]:
    """A* from ``origin`` to ``goal`` with ``move_to``'s ``options``, run in slices of
    :data:`~.sim.planner.PLAN_SLICE` expansions; ``alive`` raises to abandon it."""
    await asyncio.sleep(0)  # a costmap just built, its regions labelled next: two turns
    search = path_search(costmap, (origin.x, origin.y), (goal.x, goal.y), options)
    result = await run_in_slices(search, alive)
    if not result.ok:
        raise BackendError(f"no path: {result.reason}")
    return [Point2D(x, y) for x, y in result.path]

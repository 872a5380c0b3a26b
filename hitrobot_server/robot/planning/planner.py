"""Grid path planning: A* over a :class:`~.costmap.Costmap`, then shortcut smoothing.

The search is incremental (:meth:`PathSearch.advance` expands at most a given number of cells)
so the simulator can spread a long search over several ticks instead of stalling the event
loop; :func:`plan` runs one to completion. Budgets count expansions, not wall time, which keeps
runs deterministic.

Goal handling follows the Slamware flags: a target the robot cannot stand on is replaced by the
nearest cell it can park on (clear of the inflated zone, ``Costmap.parkable``), unless the caller
asked for ``RETURN_UNREACHABLE_DIRECTLY``. The caller decides whether the replacement is close
enough to count as the target (the navigator fails a move that ends outside its tolerance).
Virtual tracks give two modes: *strict* (``KEY_POINTS``) confines the search to track cells plus
straight connectors from the start and to the goal; *priority* (``KEY_POINTS_WITH_OA``) makes
track cells cheaper so paths follow tracks where they can and leave them to get around
obstacles.
"""

from __future__ import annotations

import asyncio
import enum
import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..model import Rect
from .costmap import Costmap, densify
from .grid import GridSpec, rasterize_segments

_SQRT2 = math.sqrt(2.0)
TRACK_COST_FACTOR = 0.3
"""Cost multiplier on virtual-track cells in priority mode."""
START_ESCAPE_RADIUS = 0.6
"""How far (m) the search may move a start that lies in a lethal cell."""
GOAL_SUBSTITUTE_RADIUS = 2.0
"""How far (m) a replacement goal may be from an unusable target."""
TRACK_CONNECT_RADIUS = 5.0
"""How far (m) strict track mode looks for a track to join or leave."""
HEURISTIC_WEIGHT = 2.0
"""Inflation of the admissible heuristic: paths may cost up to this factor more than optimal,
in exchange for an order of magnitude fewer expansions; smoothing removes most of the
difference."""


class TrackMode(enum.Enum):
    NONE = "none"
    STRICT = "strict"
    PRIORITY = "priority"


@dataclass(frozen=True, slots=True)
class PlanResult:
    """A path of map points from the start to ``goal`` (the target or its substitute), or the
    reason there is none."""

    ok: bool
    path: tuple[tuple[float, float], ...] = ()
    reason: str = ""
    goal: tuple[float, float] | None = None


class PathSearch:
    """One A* search, advanced in bounded slices."""

    def __init__(
        self,
        costmap: Costmap,
        start: tuple[float, float],
        goal: tuple[float, float],
        *,
        smooth: bool = True,
        substitute_goal: bool = True,
        track_mode: TrackMode = TrackMode.NONE,
        bbox: Rect | None = None,
        heuristic_weight: float = HEURISTIC_WEIGHT,
    ) -> None:
        self.result: PlanResult | None = None
        self.expansions = 0
        self._regions_checked = False
        self._costmap = costmap
        self._spec = spec = costmap.spec
        self._start_point = start
        self._goal_point = goal
        self._smooth = smooth and track_mode is TrackMode.NONE
        blocked = costmap.lethal.copy()  # lethal cells, the border, outside the planning area
        blocked[0, :] = blocked[-1, :] = blocked[:, 0] = blocked[:, -1] = True
        if bbox is not None:
            window = spec.window(bbox)
            inside = np.zeros(spec.shape, dtype=bool)
            if window is not None:
                inside[window] = True
            blocked |= ~inside
        cost = costmap.cost
        self._min_cost = 1.0
        self._heuristic_weight = heuristic_weight
        if track_mode is TrackMode.PRIORITY:
            cost = np.where(costmap.track, cost * np.float32(TRACK_COST_FACTOR), cost)
            self._min_cost = TRACK_COST_FACTOR

        start_cell = _nearest(spec, ~blocked, start, START_ESCAPE_RADIUS)
        if start_cell is None:
            self._fail("the robot is inside an obstacle")
            return
        goal_cell = spec.cell(*goal)
        if not spec.contains(*goal_cell) or blocked[goal_cell[1], goal_cell[0]]:
            if not substitute_goal:
                self._fail("target is occupied or unreachable")
                return
            goal_cell = _nearest(spec, ~blocked & costmap.parkable, goal,
                                 GOAL_SUBSTITUTE_RADIUS)
            if goal_cell is None:
                self._fail("no free space near the target")
                return
            self._goal_point = tuple(float(v) for v in spec.center(*goal_cell))
        if track_mode is TrackMode.STRICT:
            strict = self._restrict_to_tracks(blocked, start_cell, goal_cell)
            if strict is None:
                return
            blocked = strict
        self._begin(blocked, cost, start_cell, goal_cell)

    def _begin(self, blocked: np.ndarray, cost: np.ndarray, start_cell: tuple[int, int],
               goal_cell: tuple[int, int]) -> None:
        """The search's state: flat cell arrays, the open heap holding the start."""
        spec = self._spec
        self._blocked_mask = blocked
        self._cost_array = cost
        self._blocked = bytearray(blocked.ravel().astype(np.uint8).tobytes())
        self._cost = cost.ravel().tolist()
        width = spec.width
        self._width = width
        self._start = start_cell[1] * width + start_cell[0]
        self._goal = goal_cell[1] * width + goal_cell[0]
        self._goal_xy = goal_cell
        self._closed = bytearray(spec.width * spec.height)
        self._g: dict[int, float] = {self._start: 0.0}
        self._parent: dict[int, int] = {}
        self._heap: list[tuple[float, float, int]] = [(self._h(*start_cell), 0.0, self._start)]
        self._neighbours = [
            (1, 1, 0, 1.0),
            (-1, -1, 0, 1.0),
            (width, 0, 1, 1.0),
            (-width, 0, -1, 1.0),
            (width + 1, 1, 1, _SQRT2),
            (width - 1, -1, 1, _SQRT2),
            (-width + 1, 1, -1, _SQRT2),
            (-width - 1, -1, -1, _SQRT2),
        ]

    def advance(self, budget: int) -> PlanResult | None:
        """Expand up to ``budget`` cells; the result once the search has finished."""
        if self.result is not None:
            return self.result
        if self.expansions and not self._joined():
            return self.result
        heap, g_of, parent = self._heap, self._g, self._parent
        blocked, closed, cost = self._blocked, self._closed, self._cost
        width, goal = self._width, self._goal
        gx, gy = self._goal_xy
        weight = self._min_cost * self._heuristic_weight
        while heap and budget > 0:
            _, g, i = heapq.heappop(heap)
            if closed[i]:
                continue
            closed[i] = 1
            budget -= 1
            self.expansions += 1
            if i == goal:
                self._finish()
                return self.result
            y, x = divmod(i, width)
            for offset, dx, dy, length in self._neighbours:
                j = i + offset
                if blocked[j] or closed[j]:
                    continue
                if dx and dy and (blocked[i + dx] or blocked[i + dy * width]):
                    continue
                ng = g + length * cost[j]
                if ng < g_of.get(j, math.inf):
                    g_of[j] = ng
                    parent[j] = i
                    ax = abs(x + dx - gx)
                    ay = abs(y + dy - gy)
                    h = (ax + ay + (_SQRT2 - 2.0) * min(ax, ay)) * weight
                    heapq.heappush(heap, (ng + h, ng, j))
        if not heap:
            self._fail("no path to the target")
        return self.result

    def _joined(self) -> bool:
        """Once a search has outgrown its first slice: whether its start and goal are in one
        region of the costmap (labelled once per costmap). A search between two regions would
        explore all of the start's, often the whole map, to fail; a short one never asks."""
        if self._regions_checked:
            return True
        self._regions_checked = True
        start = divmod(self._start, self._width)[::-1]
        if self._costmap.regions.joined(self._costmap.lethal, start, self._goal_xy):
            return True
        self._fail("no path to the target")
        return False

    def _h(self, x: int, y: int) -> float:
        ax = abs(x - self._goal_xy[0])
        ay = abs(y - self._goal_xy[1])
        return (ax + ay + (_SQRT2 - 2.0) * min(ax, ay)) * self._min_cost * self._heuristic_weight

    def _fail(self, reason: str) -> None:
        self.result = PlanResult(False, reason=reason)

    def _finish(self) -> None:
        cells = [self._goal]
        while cells[-1] != self._start:
            cells.append(self._parent[cells[-1]])
        cells.reverse()
        rows, cols = np.divmod(np.array(cells), self._width)
        xs, ys = self._spec.center(cols, rows)
        points = np.stack((xs, ys), axis=1)
        points[0] = self._start_point
        points[-1] = self._goal_point
        if self._smooth and len(points) > 2:
            costs = self._cost_array[rows, cols]
            points = self._shortcut(points, costs)
        path = tuple((float(x), float(y)) for x, y in points)
        self.result = PlanResult(True, path=path, goal=path[-1])

    def _shortcut(self, points: np.ndarray, costs: np.ndarray) -> np.ndarray:
        """Greedy line-of-sight shortcutting: from each anchor jump to the farthest later point
        reachable in a straight line that neither crosses a blocked cell nor passes closer to
        obstacles than the grid path did there (so smoothing does not hug walls)."""
        out = [points[0]]
        anchor = 0
        last = len(points) - 1
        while anchor < last:
            ceiling = np.maximum.accumulate(costs[anchor:])
            lo, hi = anchor + 1, last
            if not self._visible(points[anchor], points[hi], ceiling[hi - anchor]):
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    if self._visible(points[anchor], points[mid], ceiling[mid - anchor]):
                        lo = mid
                    else:
                        hi = mid
                hi = lo
            out.append(points[hi])
            anchor = hi
        return np.array(out)

    def _visible(self, a: np.ndarray, b: np.ndarray, max_cost: float) -> bool:
        samples = densify(np.stack((a, b)), self._spec.resolution * 0.5)
        ix, iy = self._spec.cells(samples[:, 0], samples[:, 1])
        if self._blocked_mask[iy, ix].any():
            return False
        return bool((self._cost_array[iy, ix] <= max_cost + 1e-6).all())

    def _restrict_to_tracks(
        self, blocked: np.ndarray, start: tuple[int, int], goal: tuple[int, int]
    ) -> np.ndarray | None:
        """The blocked mask of strict track mode: everything but track cells and two straight
        connectors (start to the nearest track cell, nearest track cell to the goal)."""
        spec = self._spec
        on_track = self._costmap.track & ~blocked
        if not on_track.any():
            self._fail("strict track mode needs virtual tracks")
            return None
        allowed = on_track.copy()
        for cell in (start, goal):
            point = tuple(float(v) for v in spec.center(*cell))
            join = _nearest(spec, on_track, point, TRACK_CONNECT_RADIUS)
            if join is None:
                self._fail("no virtual track near the start or the target")
                return None
            jx, jy = (float(v) for v in spec.center(*join))
            connector = rasterize_segments(spec, [(point[0], point[1], jx, jy)])
            if (connector & blocked).any():
                self._fail("cannot reach a virtual track in a straight line")
                return None
            allowed |= connector
        return blocked | ~allowed


def _nearest(
    spec: GridSpec, usable: np.ndarray, point: tuple[float, float], radius: float
) -> tuple[int, int] | None:
    """The usable cell whose centre is closest to ``point`` within ``radius`` metres."""
    cx, cy = spec.cell(*point)
    if spec.contains(cx, cy) and usable[cy, cx]:
        return cx, cy
    reach = math.ceil(radius / spec.resolution)
    window = spec.window(Rect(point[0] - radius, point[1] - radius, 2 * radius, 2 * radius))
    if window is None:
        return None
    rows, cols = np.nonzero(usable[window])
    if len(rows) == 0:
        return None
    rows = rows + window[0].start
    cols = cols + window[1].start
    d2 = (rows - cy) ** 2 + (cols - cx) ** 2
    best = int(np.argmin(d2))
    if d2[best] > reach * reach:
        return None
    return int(cols[best]), int(rows[best])


PLAN_SLICE = 4_000
"""A* expansions an off-robot search (``compute_path``) runs between yields to the loop (a
search that fails explores the whole map: 20,000 held a loaded 2-core machine for over 1 s)."""


async def run_in_slices(search: PathSearch, alive: Callable[[], None],
                        budget: int = PLAN_SLICE) -> PlanResult:
    """Run ``search`` to completion ``budget`` expansions at a time, yielding to the event loop
    between slices; ``alive`` raises to abandon it (e.g. the robot went away)."""
    while (result := search.advance(budget)) is None:
        await asyncio.sleep(0)
        alive()
    return result


def plan(
    costmap: Costmap, start: tuple[float, float], goal: tuple[float, float], **kwargs
) -> PlanResult:
    """Run a :class:`PathSearch` to completion."""
    search = PathSearch(costmap, start, goal, **kwargs)
    while (result := search.advance(1 << 20)) is None:
        pass
    return result

"""The planner's view of the map: lethal cells and per-cell traversal costs.

Built from the robot's *own* explore map (not the ground truth), plus virtual walls rasterised
as obstacles and blocked polygons from callers. Obstacles are inflated by the robot radius
(cells whose centre would put the disc into an obstacle are lethal) and a cost that decays with
distance keeps paths off walls where there is room. Unknown cells stay traversable at a penalty,
so the robot can plan into unexplored space and replan when its lidar reveals walls.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..model import Line, Point2D
from .grid import GridSpec, distance_field, rasterize_polygons, rasterize_segments
from .regions import Regions


@dataclass(frozen=True, slots=True)
class CostmapConfig:
    """Inflation and cost shaping, in metres."""

    robot_radius: float = 0.2
    safety_margin: float = 0.05
    inflation_radius: float = 0.6
    inflation_cost: float = 3.0
    inflation_decay: float = 8.0
    unknown_cost: float = 1.0
    track_width: float = 0.05
    park_margin: float = 0.1
    """Room (m) beyond the lethal zone a replacement goal must have: the robot never parks
    itself on the edge of an inflated obstacle, where tracking error wedges it."""


@dataclass(frozen=True, slots=True, eq=False)
class Costmap:
    """``lethal[row, col]``: the robot centre may not be there. ``cost``: multiplier >= 1 on the
    length of a step into the cell. ``track``: cells on a virtual track (for track modes).
    ``parkable``: cells with room to stop in, clear of the inflated zone by ``park_margin``
    (where a goal that cannot be stood on is moved to). ``regions``: which free cells join,
    labelled on first use."""

    spec: GridSpec
    lethal: np.ndarray
    cost: np.ndarray
    track: np.ndarray
    parkable: np.ndarray
    regions: Regions = field(default_factory=Regions, compare=False, repr=False)

    def lethal_at(self, points: np.ndarray) -> np.ndarray:
        """Per point ``(n, 2)``: whether the robot centre may not be there (outside = lethal)."""
        ix, iy = self.spec.cells(points[:, 0], points[:, 1])
        inside = (ix >= 0) & (ix < self.spec.width) & (iy >= 0) & (iy < self.spec.height)
        out = np.ones(len(points), dtype=bool)
        out[inside] = self.lethal[iy[inside], ix[inside]]
        return out


def build_costmap(
    spec: GridSpec,
    occupied: np.ndarray,
    unknown: np.ndarray,
    config: CostmapConfig,
    walls: Sequence[Line] = (),
    blocked: Sequence[Sequence[Point2D]] = (),
    tracks: Sequence[Line] = (),
) -> Costmap:
    """Combine map, virtual walls and blocked areas into a :class:`Costmap`."""
    res = spec.resolution
    obstacles = occupied.copy()
    if walls:
        obstacles |= rasterize_segments(spec, (_segment(w) for w in walls))
    if blocked:
        obstacles |= rasterize_polygons(spec, blocked)
    max_cells = math.ceil(config.inflation_radius / res)
    clearance = distance_field(obstacles, max_cells) * np.float32(res)
    # Distances run between cell centres; half a cell converts that to the distance to the
    # obstacle's edge, and the safety margin absorbs path-tracking error.
    lethal = clearance < config.robot_radius + 0.5 * res + config.safety_margin
    parkable = ~lethal & (clearance >= config.robot_radius + 0.5 * res + config.safety_margin
                          + config.park_margin)
    excess = np.maximum(clearance - config.robot_radius, 0.0)
    cost = 1.0 + config.inflation_cost * np.exp(-config.inflation_decay * excess)
    cost = np.where(clearance >= config.inflation_radius, 1.0, cost).astype(np.float32)
    cost[unknown & ~obstacles] += np.float32(config.unknown_cost)
    track = np.zeros(spec.shape, dtype=bool)
    if tracks:
        line = rasterize_segments(spec, (_segment(t) for t in tracks))
        reach = max(1, round(config.track_width / res))
        track = distance_field(line, reach + 1) <= reach
    return Costmap(spec, lethal, cost, track, parkable)


def densify(points: np.ndarray, step: float) -> np.ndarray:
    """Points along a polyline no more than ``step`` apart (the vertices included)."""
    out = [points[:1]]
    for a, b in zip(points[:-1], points[1:], strict=True):
        n = max(1, math.ceil(float(np.hypot(*(b - a))) / step))
        t = np.arange(1, n + 1)[:, None] / n
        out.append(a + (b - a) * t)
    return np.concatenate(out)


def _segment(line: Line) -> tuple[float, float, float, float]:
    return (line.start.x, line.start.y, line.end.x, line.end.y)

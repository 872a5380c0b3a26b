"""The other robots of a shared world as one robot meets them (:class:`Neighbours`, a part of
:class:`~.simulator.Simulator`): discs its lidar sees, and obstacles in its costmap while they
are in lidar range."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..model import Pose2D
from ..planning.costmap import Costmap
from .config import SimConfig


class Neighbours:
    """What the others' true poses do to this robot's scan and costmap; the costmap with them
    is kept until one moved by a quarter metre or the map's costmap changed."""

    def __init__(self, config: SimConfig) -> None:
        self._config = config
        self._cached: tuple[tuple, Costmap, Costmap] | None = None

    def in_scan(self, ranges: np.ndarray, origin: Pose2D, angles: np.ndarray,
                others: Sequence[Pose2D]) -> np.ndarray:
        """``ranges`` cut short where a beam meets another robot's disc."""
        if not others:
            return ranges
        return np.minimum(ranges, discs_along_rays(
            origin, angles, others, self._config.drive.radius, self._config.lidar.max_range))

    def costmap(self, base: Costmap, me: Pose2D, others: Sequence[Pose2D]) -> Costmap:
        """``base`` with the others in lidar range of ``me`` as obstacles."""
        reach = self._config.lidar.max_range
        seen = tuple((round(p.x * 4) / 4, round(p.y * 4) / 4) for p in others
                     if math.hypot(p.x - me.x, p.y - me.y) <= reach)
        if not seen:
            return base
        cached = self._cached
        if cached is None or cached[0] != seen or cached[1] is not base:
            cached = self._cached = (seen, base, with_robots(base, seen, self._config))
        return cached[2]


def discs_along_rays(origin: Pose2D, angles: np.ndarray, centres: Sequence[Pose2D],
                     radius: float, max_range: float) -> np.ndarray:
    """Per beam (angles relative to ``origin``'s heading): the distance to the first disc of
    ``radius`` around any of ``centres``, or ``inf``."""
    world = np.asarray(angles) + origin.yaw
    ux, uy = np.cos(world), np.sin(world)
    out = np.full(world.shape, np.inf)
    for c in centres:
        cx, cy = c.x - origin.x, c.y - origin.y
        along = ux * cx + uy * cy
        miss2 = (cx * cx + cy * cy) - along * along
        inside = radius * radius - miss2
        t = along - np.sqrt(np.maximum(inside, 0.0))
        hit = (inside >= 0.0) & (t > 0.0) & (t <= max_range)
        out = np.where(hit, np.minimum(out, t), out)
    return out


def with_robots(base: Costmap, centres: Sequence[tuple[float, float]],
                config: SimConfig) -> Costmap:
    """``base`` with a robot's disc (as wide as this one) at each of ``centres``, inflated as
    :func:`build_costmap` inflates obstacles: lethal where the discs would touch (plus the
    safety margin), a decaying cost around, not parkable up to the park margin."""
    spec = base.spec
    c = config.costmap
    radius = config.drive.radius
    lethal_reach = 2 * radius + 0.5 * spec.resolution + c.safety_margin
    park_reach = lethal_reach + c.park_margin
    lethal, parkable, cost = base.lethal.copy(), base.parkable.copy(), base.cost.copy()
    span = math.ceil((radius + max(park_reach, c.inflation_radius)) / spec.resolution) + 1
    for x, y in centres:
        ix, iy = spec.cell(x, y)
        x0, x1 = max(ix - span, 0), min(ix + span + 1, spec.width)
        y0, y1 = max(iy - span, 0), min(iy + span + 1, spec.height)
        if x0 >= x1 or y0 >= y1:
            continue
        cx, cy = spec.center(np.arange(x0, x1)[None, :], np.arange(y0, y1)[:, None])
        d = np.hypot(cx - x, cy - y)
        lethal[y0:y1, x0:x1] |= d < lethal_reach
        parkable[y0:y1, x0:x1] &= d >= park_reach
        clearance = d - radius  # to the other disc's edge
        extra = 1.0 + c.inflation_cost * np.exp(-c.inflation_decay
                                                * np.maximum(clearance - radius, 0.0))
        extra = np.where(clearance < c.inflation_radius, extra, 1.0).astype(np.float32)
        np.maximum(cost[y0:y1, x0:x1], extra, out=cost[y0:y1, x0:x1])
    return Costmap(spec, lethal, cost, base.track, parkable)

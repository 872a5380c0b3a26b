"""The node's local copy of the robot's explore map, kept in sync like the real node's.

A full sync pulls the whole known area in tiles; between full syncs only a window around
the robot is refreshed, so a large map costs little per update (slamware_ros_sdk's
server_map_holder / ExploreMapUpdate worker).
"""

from __future__ import annotations

import math

import numpy as np

from ...robot.model import MapRegion, Rect
from .messages import OCCUPANCY_LUT

GROW_MARGIN = 32  # cells added around the map whenever it grows
MAX_CELLS_SIDE = 20_000  # a remembered extent larger than this is not believed


class MapHolder:
    """Explore-map cells (Slamware bytes) over a growing rectangle of the global cell grid."""

    def __init__(self) -> None:
        self.resolution: float | None = None
        self.cells = np.zeros((0, 0), dtype=np.uint8)
        self.col0 = 0  # global cell index of cells[:, 0]
        self.row0 = 0  # global cell index of cells[0, :]

    def reset(self, resolution: float) -> None:
        self.resolution = resolution
        self.clear()

    def clear(self) -> None:
        self.cells = np.zeros((0, 0), dtype=np.uint8)
        self.col0 = self.row0 = 0

    def forget(self) -> None:
        """Every cell unknown, the extent kept: what to publish once the robot's map is gone
        (a latched old map must not outlive it)."""
        self.cells[:] = 0

    @property
    def empty(self) -> bool:
        return self.cells.size == 0

    def extent(self) -> dict | None:
        """Where the cells lie (resolution, first column and row, width, height)."""
        if self.resolution is None or self.empty:
            return None
        h, w = self.cells.shape
        return {"resolution": self.resolution, "col0": self.col0, "row0": self.row0,
                "width": w, "height": h}

    def unknown_over(self, extent: dict) -> bool:
        """Every cell unknown over a remembered :meth:`extent` (a cleared map after a
        restart); False when it does not fit this holder's resolution."""
        try:
            res, col0, row0 = float(extent["resolution"]), int(extent["col0"]), int(extent["row0"])
            w, h = int(extent["width"]), int(extent["height"])
        except (KeyError, TypeError, ValueError):
            return False
        if self.resolution is None or not math.isclose(res, self.resolution) \
                or not (0 < w <= MAX_CELLS_SIDE and 0 < h <= MAX_CELLS_SIDE):
            return False
        self.cells = np.zeros((h, w), dtype=np.uint8)
        self.col0, self.row0 = col0, row0
        return True

    def _cell(self, metres: float) -> int:
        return int(math.floor(metres / self.resolution + 0.5))

    def merge(self, region: MapRegion) -> bool:
        """Paste a fetched window; False when its resolution is not ours (caller re-inits)."""
        if self.resolution is None or not math.isclose(region.resolution, self.resolution):
            return False
        h, w = region.cells.shape
        if h == 0 or w == 0:
            return True
        col, row = self._cell(region.origin_x), self._cell(region.origin_y)
        self._cover(col, row, col + w, row + h)
        c, r = col - self.col0, row - self.row0
        self.cells[r:r + h, c:c + w] = region.cells
        return True

    def _cover(self, c0: int, r0: int, c1: int, r1: int) -> None:
        h, w = self.cells.shape
        if self.cells.size and (c0 >= self.col0 and r0 >= self.row0
                                and c1 <= self.col0 + w and r1 <= self.row0 + h):
            return
        if self.cells.size:
            nc0, nr0 = min(c0, self.col0), min(r0, self.row0)
            nc1, nr1 = max(c1, self.col0 + w), max(r1, self.row0 + h)
            nc0 -= GROW_MARGIN if nc0 < self.col0 else 0
            nr0 -= GROW_MARGIN if nr0 < self.row0 else 0
            nc1 += GROW_MARGIN if nc1 > self.col0 + w else 0
            nr1 += GROW_MARGIN if nr1 > self.row0 + h else 0
        else:
            nc0, nr0, nc1, nr1 = c0, r0, c1, r1
        grown = np.zeros((nr1 - nr0, nc1 - nc0), dtype=np.uint8)
        if self.cells.size:
            grown[self.row0 - nr0:self.row0 - nr0 + h, self.col0 - nc0:self.col0 - nc0 + w] = (
                self.cells
            )
        self.cells, self.col0, self.row0 = grown, nc0, nr0

    def occupancy(self) -> tuple[np.ndarray, float, float]:
        """ROS occupancy values (int8, row 0 = min y) and the lower-left origin in metres."""
        return (OCCUPANCY_LUT[self.cells].ravel(), self.col0 * self.resolution,
                self.row0 * self.resolution)


def tiles(area: Rect, size: float) -> list[Rect]:
    """Square tiles of ``size`` metres covering ``area`` (the full-sync fetch plan)."""
    out = []
    y = area.y
    while y < area.y + area.height - 1e-9:
        x = area.x
        while x < area.x + area.width - 1e-9:
            out.append(Rect(x, y, min(size, area.x + area.width - x),
                            min(size, area.y + area.height - y)))
            x += size
        y += size
    return out


def window(area: Rect, cx: float, cy: float, half: float) -> Rect | None:
    """The square of half-side ``half`` around (cx, cy), clipped to ``area``; None if empty."""
    x0, y0 = max(area.x, cx - half), max(area.y, cy - half)
    x1 = min(area.x + area.width, cx + half)
    y1 = min(area.y + area.height, cy + half)
    if x1 <= x0 or y1 <= y0:
        return None
    return Rect(x0, y0, x1 - x0, y1 - y0)

"""Grid geometry shared by every map-shaped array in the simulator.

All grids use the Slamware/ROS convention: ``array[row, col]`` with row 0 at the minimum y and
the origin at the lower-left corner of cell (0, 0). Keeping one convention everywhere means an
explore-map crop can be handed out without flipping.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw

from ..model import Point2D, Rect


@dataclass(frozen=True, slots=True)
class GridSpec:
    """Placement and size of a grid in the map frame."""

    origin_x: float
    origin_y: float
    resolution: float
    width: int
    height: int

    @property
    def shape(self) -> tuple[int, int]:
        return (self.height, self.width)

    def cell(self, x: float, y: float) -> tuple[int, int]:
        """Column and row of the cell containing ``(x, y)`` (may be outside the grid)."""
        return (
            math.floor((x - self.origin_x) / self.resolution),
            math.floor((y - self.origin_y) / self.resolution),
        )

    def cells(self, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised :meth:`cell`."""
        ix = np.floor((xs - self.origin_x) / self.resolution).astype(np.int64)
        iy = np.floor((ys - self.origin_y) / self.resolution).astype(np.int64)
        return ix, iy

    def contains(self, ix: int, iy: int) -> bool:
        return 0 <= ix < self.width and 0 <= iy < self.height

    def center(self, ix: int | np.ndarray, iy: int | np.ndarray) -> tuple:
        """Map coordinates of cell centres."""
        return (
            self.origin_x + (np.asarray(ix) + 0.5) * self.resolution,
            self.origin_y + (np.asarray(iy) + 0.5) * self.resolution,
        )

    def extent(self) -> Rect:
        return Rect(
            self.origin_x,
            self.origin_y,
            self.width * self.resolution,
            self.height * self.resolution,
        )

    def window(self, rect: Rect) -> tuple[slice, slice] | None:
        """Row and column slices of the cells overlapping ``rect``, or ``None`` if none do."""
        eps = 1e-9
        c0 = max(0, math.floor((rect.x - self.origin_x) / self.resolution + eps))
        r0 = max(0, math.floor((rect.y - self.origin_y) / self.resolution + eps))
        c1 = min(
            self.width, math.ceil((rect.x + rect.width - self.origin_x) / self.resolution - eps)
        )
        r1 = min(
            self.height, math.ceil((rect.y + rect.height - self.origin_y) / self.resolution - eps)
        )
        if c1 <= c0 or r1 <= r0:
            return None
        return slice(r0, r1), slice(c0, c1)


def distance_field(obstacles: np.ndarray, max_cells: int) -> np.ndarray:
    """Euclidean distance, in cells, from every cell centre to the nearest obstacle centre.

    Exact up to ``max_cells`` and clipped there. It is computed separably (a bounded column pass,
    then a bounded row pass over the squared column distances), which costs O(max_cells) whole
    array operations instead of a Python loop per cell.
    """
    far = np.float32(max_cells + 1)
    column = np.where(obstacles, np.float32(0.0), far).astype(np.float32)
    height, width = obstacles.shape
    for d in range(1, min(max_cells, height - 1) + 1):
        step = np.float32(d)
        np.minimum(column[d:], np.where(obstacles[:-d], step, far), out=column[d:])
        np.minimum(column[:-d], np.where(obstacles[d:], step, far), out=column[:-d])
    squared = column * column
    best = squared.copy()
    for d in range(1, min(max_cells, width - 1) + 1):
        offset = np.float32(d * d)
        np.minimum(best[:, d:], squared[:, :-d] + offset, out=best[:, d:])
        np.minimum(best[:, :-d], squared[:, d:] + offset, out=best[:, :-d])
    return np.minimum(np.sqrt(best), np.float32(max_cells))


def rasterize_segments(
    spec: GridSpec, segments: Iterable[tuple[float, float, float, float]]
) -> np.ndarray:
    """Mask of the cells touched by each segment ``(x0, y0, x1, y1)``.

    Sampling at a quarter cell marks every cell the segment crosses, so the result is
    4-connected and a planner cannot slip diagonally through it.
    """
    mask = np.zeros(spec.shape, dtype=bool)
    for x0, y0, x1, y1 in segments:
        length = math.hypot(x1 - x0, y1 - y0)
        n = max(2, math.ceil(length / (spec.resolution * 0.25)) + 1)
        t = np.linspace(0.0, 1.0, n)
        ix, iy = spec.cells(x0 + (x1 - x0) * t, y0 + (y1 - y0) * t)
        inside = (ix >= 0) & (ix < spec.width) & (iy >= 0) & (iy < spec.height)
        mask[iy[inside], ix[inside]] = True
    return mask


def rasterize_polygons(spec: GridSpec, polygons: Iterable[Sequence[Point2D]]) -> np.ndarray:
    """Mask of the cells inside (or on the outline of) each polygon, drawn with Pillow."""
    image = Image.new("1", (spec.width, spec.height), 0)
    draw = ImageDraw.Draw(image)
    for polygon in polygons:
        corners = [((p.x - spec.origin_x) / spec.resolution,
                    (p.y - spec.origin_y) / spec.resolution) for p in polygon]
        if len(corners) >= 3:
            draw.polygon(corners, fill=1, outline=1)
        elif corners:
            draw.line(corners, fill=1, width=1)
    return np.asarray(image, dtype=bool)

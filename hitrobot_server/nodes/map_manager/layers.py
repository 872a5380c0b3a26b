"""Map layers and their composition into ``/map`` (pure: numpy and Pillow, no bus, no robot).

Four layers, numbered as in ``map_messages/MapLayers``:

``SLAM_LAYER`` (0)     the robot's own map (the Slamware node's ``map`` topic);
``MASKING_LAYER`` (1)  nothing of its own: user masks only;
``KINECT_LAYER`` (2)   obstacles seen by the (simulated) depth camera;
``SICK_LAYER`` (3)     obstacles seen by the lidar.

Every layer can carry user masks (``ModifyMap``): cells set to FREE (0), OBSTACLE (99) or BLOCKED
(100), or cleared again with NOT_MASKED (-1). The mask values are the occupancy values they
produce, so the composition is plain painting, in layer order, of the enabled layers:

1. the SLAM map (or unknown, -1, where there is none or the layer is off), then its masks;
2. the masking layer's masks;
3. each obstacle layer: its sensor hits as OBSTACLE (99) except where the picture already says
   BLOCKED/occupied (100, so a wall the lidar sees stays a wall), then its masks.

Masks live on their own grid (a window of a global cell lattice anchored at (0, 0), at the map's
resolution when they were first drawn), so they survive the SLAM map growing, shrinking or being
replaced, and are sampled at the centre of each output cell.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw

SLAM_LAYER, MASKING_LAYER, KINECT_LAYER, SICK_LAYER = 0, 1, 2, 3
LAYER_NAMES = {
    SLAM_LAYER: "SLAM_LAYER",
    MASKING_LAYER: "MASKING_LAYER",
    KINECT_LAYER: "KINECT_LAYER",
    SICK_LAYER: "SICK_LAYER",
}
OBSTACLE_LAYERS = (KINECT_LAYER, SICK_LAYER)
DEFAULT_STATES = {SLAM_LAYER: True, MASKING_LAYER: True, KINECT_LAYER: False, SICK_LAYER: False}

FREE, OBSTACLE, BLOCKED, NOT_MASKED = 0, 99, 100, -1
MASK_ACTIONS = {FREE: "FREE", OBSTACLE: "OBSTACLE", BLOCKED: "BLOCKED", NOT_MASKED: "NOT_MASKED"}
UNKNOWN = -1
OCCUPIED = 100

EDGE_EPSILON = 1e-6
"""Cells: how far polygon vertices are pulled inwards before rasterising."""
MAX_MASK_CELLS = 16_000_000
"""Largest mask window (cells) a layer may grow to: 200 m x 200 m at 5 cm. A polygon that would
need more is refused rather than allocating gigabytes."""


class LayerError(ValueError):
    """A request the layers refuse; the text is user-facing."""


@dataclass(frozen=True, slots=True, eq=False)
class Grid:
    """An occupancy grid as ROS has it: ``data[row, col]`` int8 (-1 unknown, 0..100), row 0 at
    the minimum y, ``(origin_x, origin_y)`` the lower-left corner of cell (0, 0)."""

    origin_x: float
    origin_y: float
    resolution: float
    data: np.ndarray

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    def same_as(self, other: Grid | None) -> bool:
        return (
            other is not None
            and other.data.shape == self.data.shape
            and math.isclose(other.origin_x, self.origin_x, abs_tol=1e-9)
            and math.isclose(other.origin_y, self.origin_y, abs_tol=1e-9)
            and math.isclose(other.resolution, self.resolution)
            and np.array_equal(other.data, self.data)
        )


Point = tuple[float, float]


def rasterize_polygon(
    shape: tuple[int, int], origin: Point, resolution: float, polygon: Sequence[Point]
) -> np.ndarray:
    """Cells of a ``shape`` grid at ``origin``/``resolution`` that ``polygon`` overlaps, drawn
    with Pillow (which marks every pixel a closed polygon touches, pixel ``i`` spanning
    ``[i, i + 1)``). Vertices are first pulled a hair towards the polygon's middle so an edge
    lying exactly on a cell border does not take the neighbouring cell too."""
    height, width = shape
    corners = np.array([((x - origin[0]) / resolution, (y - origin[1]) / resolution)
                        for x, y in polygon], dtype=np.float64)
    towards = corners.mean(axis=0) - corners
    length = np.hypot(towards[:, 0], towards[:, 1])
    corners += towards * (EDGE_EPSILON / np.maximum(length, EDGE_EPSILON))[:, None]
    image = Image.new("1", (width, height), 0)
    ImageDraw.Draw(image).polygon([(float(x), float(y)) for x, y in corners], fill=1, outline=1)
    return np.asarray(image, dtype=bool)


class Mask:
    """One layer's user masks: int8 cells (NOT_MASKED, FREE, OBSTACLE, BLOCKED) over a window
    ``[col0, col0 + w) x [row0, row0 + h)`` of the lattice of ``resolution``-sized cells."""

    def __init__(self, resolution: float) -> None:
        if not (math.isfinite(resolution) and resolution > 0):
            raise LayerError("mask resolution must be positive")
        self.resolution = resolution
        self.col0 = 0
        self.row0 = 0
        self.cells = np.full((0, 0), NOT_MASKED, dtype=np.int8)

    @classmethod
    def from_cells(cls, resolution: float, col0: int, row0: int, cells: np.ndarray) -> Mask:
        mask = cls(resolution)
        values = np.asarray(cells, dtype=np.int8)
        if not np.isin(values, list(MASK_ACTIONS)).all():
            raise LayerError("mask cells must be -1, 0, 99 or 100")
        mask.col0, mask.row0, mask.cells = int(col0), int(row0), values.copy()
        mask.trim()
        return mask

    @property
    def empty(self) -> bool:
        return not (self.cells != NOT_MASKED).any()

    @property
    def origin(self) -> Point:
        return self.col0 * self.resolution, self.row0 * self.resolution

    def paint(self, polygon: Sequence[Point], action: int) -> int:
        """Set the cells of ``polygon`` to ``action``; the number of cells painted."""
        if action not in MASK_ACTIONS:
            raise LayerError(f"unknown mask action {action}")
        check_polygon(polygon)
        res = self.resolution
        xs, ys = [p[0] for p in polygon], [p[1] for p in polygon]
        c0, c1 = math.floor(min(xs) / res) - 1, math.floor(max(xs) / res) + 2
        r0, r1 = math.floor(min(ys) / res) - 1, math.floor(max(ys) / res) + 2
        if action == NOT_MASKED:
            if self.cells.size == 0:
                return 0
            h, w = self.cells.shape
            c0, r0 = max(c0, self.col0), max(r0, self.row0)
            c1, r1 = min(c1, self.col0 + w), min(r1, self.row0 + h)
            if c1 <= c0 or r1 <= r0:
                return 0
        else:
            if (c1 - c0) * (r1 - r0) > MAX_MASK_CELLS:
                raise LayerError("the region is too large to mask")
            self._cover(c0, r0, c1, r1)
        inside = rasterize_polygon((r1 - r0, c1 - c0), (c0 * res, r0 * res), res, polygon)
        rows = slice(r0 - self.row0, r1 - self.row0)
        cols = slice(c0 - self.col0, c1 - self.col0)
        self.cells[rows, cols][inside] = action
        self.trim()
        return int(inside.sum())

    def _cover(self, c0: int, r0: int, c1: int, r1: int) -> None:
        if self.cells.size:
            h, w = self.cells.shape
            c0, r0 = min(c0, self.col0), min(r0, self.row0)
            c1, r1 = max(c1, self.col0 + w), max(r1, self.row0 + h)
            if (c0, r0, c1, r1) == (self.col0, self.row0, self.col0 + w, self.row0 + h):
                return
        if (c1 - c0) * (r1 - r0) > MAX_MASK_CELLS:
            raise LayerError("the masked area would grow too large")
        grown = np.full((r1 - r0, c1 - c0), NOT_MASKED, dtype=np.int8)
        if self.cells.size:
            h, w = self.cells.shape
            grown[self.row0 - r0:self.row0 - r0 + h, self.col0 - c0:self.col0 - c0 + w] = (
                self.cells
            )
        self.cells, self.col0, self.row0 = grown, c0, r0

    def trim(self) -> None:
        """Shrink the window to the masked cells."""
        used = self.cells != NOT_MASKED
        if not used.any():
            self.cells = np.full((0, 0), NOT_MASKED, dtype=np.int8)
            self.col0 = self.row0 = 0
            return
        rows, cols = np.flatnonzero(used.any(axis=1)), np.flatnonzero(used.any(axis=0))
        self.cells = self.cells[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1].copy()
        self.row0 += int(rows[0])
        self.col0 += int(cols[0])

    def extent(self) -> tuple[float, float, float, float] | None:
        """(x0, y0, x1, y1) of the window, or None when nothing is masked."""
        if self.empty:
            return None
        h, w = self.cells.shape
        res = self.resolution
        return (self.col0 * res, self.row0 * res, (self.col0 + w) * res, (self.row0 + h) * res)

    def sample(self, origin: Point, resolution: float, shape: tuple[int, int]) -> np.ndarray:
        """The mask at the centres of the cells of another grid (NOT_MASKED outside)."""
        out = np.full(shape, NOT_MASKED, dtype=np.int8)
        if self.empty:
            return out
        h, w = shape
        xs = origin[0] + (np.arange(w) + 0.5) * resolution
        ys = origin[1] + (np.arange(h) + 0.5) * resolution
        ix = np.floor(xs / self.resolution).astype(np.int64) - self.col0
        iy = np.floor(ys / self.resolution).astype(np.int64) - self.row0
        mh, mw = self.cells.shape
        cols_ok = (ix >= 0) & (ix < mw)
        rows_ok = (iy >= 0) & (iy < mh)
        if not cols_ok.any() or not rows_ok.any():
            return out
        out[np.ix_(rows_ok, cols_ok)] = self.cells[np.ix_(iy[rows_ok], ix[cols_ok])]
        return out

    def rectangles(self, values: Iterable[int]) -> list[tuple[float, float, float, float]]:
        """The cells holding any of ``values`` as few axis-aligned (x0, y0, x1, y1) rectangles
        on cell edges: runs per row, merged with identical runs in the rows above."""
        if self.empty:
            return []
        hit = np.isin(self.cells, list(values))
        res = self.resolution
        open_runs: dict[tuple[int, int], int] = {}  # (c0, c1) -> first row
        out: list[tuple[int, int, int, int]] = []
        for r in range(hit.shape[0] + 1):
            runs = set(_runs(hit[r])) if r < hit.shape[0] else set()
            for run in list(open_runs):
                if run not in runs:
                    out.append((run[0], open_runs.pop(run), run[1], r))
            for run in runs:
                open_runs.setdefault(run, r)
        return [((self.col0 + c0) * res, (self.row0 + r0) * res,
                 (self.col0 + c1) * res, (self.row0 + r1) * res) for c0, r0, c1, r1 in out]


def _runs(row: np.ndarray) -> list[tuple[int, int]]:
    """Half-open [start, end) runs of True in a boolean row."""
    padded = np.concatenate(([False], row, [False]))
    edges = np.flatnonzero(padded[1:] != padded[:-1])
    return [(int(edges[i]), int(edges[i + 1])) for i in range(0, len(edges), 2)]


def check_polygon(polygon: Sequence[Point]) -> None:
    if len(polygon) < 3:
        raise LayerError("a region needs at least 3 points")
    if not all(math.isfinite(x) and math.isfinite(y) for x, y in polygon):
        raise LayerError("region points must be finite numbers")
    xs, ys = [p[0] for p in polygon], [p[1] for p in polygon]
    if max(xs) - min(xs) <= 0 or max(ys) - min(ys) <= 0:
        raise LayerError("the region has no area")


def scan_hits(
    pose: tuple[float, float, float],
    angles: np.ndarray,
    ranges: np.ndarray,
    *,
    fov: float | None = None,
    min_range: float = 0.0,
    max_range: float = math.inf,
) -> np.ndarray:
    """Map-frame points of the beams that returned within ``[min_range, max_range]`` and, with
    ``fov``, within ``±fov/2`` of the sensor's heading; ``(n, 2)``."""
    angles = np.asarray(angles, dtype=np.float64)
    ranges = np.asarray(ranges, dtype=np.float64)
    keep = np.isfinite(ranges) & (ranges > 0) & (ranges >= min_range) & (ranges <= max_range)
    if fov is not None:
        keep &= np.abs(np.remainder(angles + math.pi, 2 * math.pi) - math.pi) <= fov / 2
    x, y, yaw = pose
    a, r = angles[keep] + yaw, ranges[keep]
    return np.stack((x + r * np.cos(a), y + r * np.sin(a)), axis=1)


def compose(
    slam: Grid | None,
    states: dict[int, bool],
    masks: dict[int, Mask],
    hits: dict[int, np.ndarray],
    default_resolution: float = 0.05,
) -> Grid | None:
    """The ``/map`` picture (see the module text); None when there is nothing to show.

    The output lies on the SLAM map's lattice, grown to cover the masks of enabled layers.
    """
    enabled = [layer for layer in LAYER_NAMES if states.get(layer, False)]
    extents = [e for layer in enabled if layer in masks
               if (e := masks[layer].extent()) is not None]
    if slam is None and not extents:
        return None
    if slam is not None:
        res, ox, oy = slam.resolution, slam.origin_x, slam.origin_y
        x0, y0 = ox, oy
        x1, y1 = ox + slam.width * res, oy + slam.height * res
    else:
        res, ox, oy = default_resolution, 0.0, 0.0
        x0 = y0 = math.inf
        x1 = y1 = -math.inf
    for ex0, ey0, ex1, ey1 in extents:
        x0, y0, x1, y1 = min(x0, ex0), min(y0, ey0), max(x1, ex1), max(y1, ey1)
    c0 = math.floor((x0 - ox) / res + 1e-6)
    r0 = math.floor((y0 - oy) / res + 1e-6)
    c1 = math.ceil((x1 - ox) / res - 1e-6)
    r1 = math.ceil((y1 - oy) / res - 1e-6)
    if (c1 - c0) * (r1 - r0) > 4 * MAX_MASK_CELLS:
        raise LayerError("the composed map would be too large")
    origin = (ox + c0 * res, oy + r0 * res)
    shape = (r1 - r0, c1 - c0)
    out = np.full(shape, UNKNOWN, dtype=np.int8)
    if slam is not None and states.get(SLAM_LAYER, False):
        out[-r0:-r0 + slam.height, -c0:-c0 + slam.width] = slam.data
    for layer in enabled:
        if layer in OBSTACLE_LAYERS:
            points = hits.get(layer)
            if points is not None and len(points):
                ix = np.floor((points[:, 0] - origin[0]) / res).astype(np.int64)
                iy = np.floor((points[:, 1] - origin[1]) / res).astype(np.int64)
                ok = (ix >= 0) & (ix < shape[1]) & (iy >= 0) & (iy < shape[0])
                ix, iy = ix[ok], iy[ok]
                seen = out[iy, ix]
                out[iy, ix] = np.where(seen == OCCUPIED, OCCUPIED, OBSTACLE)
        mask = masks.get(layer)
        if mask is not None and not mask.empty:
            sampled = mask.sample(origin, res, shape)
            painted = sampled != NOT_MASKED
            out[painted] = sampled[painted]
    return Grid(origin[0], origin[1], res, out)


def blocked_rectangles(
    states: dict[int, bool], masks: dict[int, Mask]
) -> list[tuple[float, float, float, float]]:
    """The BLOCKED and OBSTACLE mask cells of the enabled layers, as rectangles: what the
    robot's planner must keep out of."""
    out: list[tuple[float, float, float, float]] = []
    for layer, mask in sorted(masks.items()):
        if states.get(layer, False):
            out.extend(mask.rectangles((BLOCKED, OBSTACLE)))
    return out

"""The robot's explore map, built from its own scans.

Each cell holds a clamped log-odds value: scan endpoints add evidence of occupancy, cells a beam
passes through add evidence of free space (each cell counted once per scan). Cells no beam has
touched stay unknown. The map is written from the *believed* pose, so a robot that is badly
localized smears its map, as a real one would.

Slamware cell encoding (read as a signed byte): 0 = unknown; 1..127 = free, 127 the most
certain; 128..255 = occupied, 128 the most certain (signed -128). A freshly observed cell with
no net evidence encodes as 1 (barely free) so it is not mistaken for unknown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import MapRegion, Pose2D, Rect
from ..planning.grid import GridSpec


@dataclass(frozen=True, slots=True)
class MappingConfig:
    hit: float = 0.85
    miss: float = 0.4
    clamp: float = 4.0


def encode_cells(logodds: np.ndarray, observed: np.ndarray, clamp: float) -> np.ndarray:
    """Log-odds to Slamware explore-map bytes."""
    level = np.clip(logodds / clamp, -1.0, 1.0)
    free = np.clip(np.rint(1.0 - level * 126.0), 1, 127)
    occupied = 256.0 + np.clip(np.rint(-level * 128.0), -128, -1)
    cells = np.where(level <= 0.0, free, occupied)
    return np.where(observed, cells, 0).astype(np.uint8)


def decode_cells(cells: np.ndarray, clamp: float) -> tuple[np.ndarray, np.ndarray]:
    """Slamware explore-map bytes back to (log-odds, observed); inverse of :func:`encode_cells`
    up to rounding."""
    value = cells.astype(np.float32)
    free = -(value - 1.0) / 126.0 * clamp
    occupied = (256.0 - value) / 128.0 * clamp
    logodds = np.where(value >= 128.0, occupied, free)
    observed = cells != 0
    return np.where(observed, logodds, 0.0).astype(np.float32), observed


class ExploreMapper:
    """Log-odds occupancy grid over the world's extent."""

    def __init__(self, spec: GridSpec, config: MappingConfig | None = None) -> None:
        self.spec = spec
        self.config = config or MappingConfig()
        self.enabled = True
        self.revision = 0
        self._logodds = np.zeros(spec.shape, dtype=np.float32)
        self._observed = np.zeros(spec.shape, dtype=bool)
        self._cells: np.ndarray | None = None

    def integrate(self, pose: Pose2D, angles: np.ndarray, ranges: np.ndarray) -> None:
        """Write one scan taken at ``pose`` (beams with ``inf`` range are ignored)."""
        if not self.enabled:
            return
        valid = np.isfinite(ranges)
        if not valid.any():
            return
        spec = self.spec
        res = spec.resolution
        world = angles[valid] + pose.yaw
        r = ranges[valid]
        cos, sin = np.cos(world), np.sin(world)
        hit_ix, hit_iy = spec.cells(pose.x + r * cos, pose.y + r * sin)
        step = res * 0.5
        t = np.arange(math.ceil(float(r.max()) / step), dtype=np.float64) * step
        along = t[None, :] < (r[:, None] - res)
        free_ix, free_iy = spec.cells(pose.x + cos[:, None] * t, pose.y + sin[:, None] * t)
        hits = self._flat(hit_ix, hit_iy)
        free = np.setdiff1d(self._flat(free_ix[along], free_iy[along]), hits, assume_unique=True)
        cfg = self.config
        flat = self._logodds.reshape(-1)
        flat[free] = np.maximum(flat[free] - cfg.miss, -cfg.clamp)
        flat[hits] = np.minimum(flat[hits] + cfg.hit, cfg.clamp)
        seen = self._observed.reshape(-1)
        seen[free] = True
        seen[hits] = True
        self._changed()

    def clear(self) -> None:
        """Forget everything (the map becomes all unknown)."""
        self._logodds.fill(0.0)
        self._observed.fill(False)
        self._changed()

    def seed(self, occupied: np.ndarray, free: np.ndarray) -> None:
        """Start from a finished map, as a robot booting with a stored map does."""
        clamp = self.config.clamp
        self._logodds = np.where(occupied, clamp, np.where(free, -clamp, 0.0)).astype(np.float32)
        self._observed = occupied | free
        self._changed()

    def cells(self) -> np.ndarray:
        """The whole grid in Slamware encoding (cached until the next change; do not modify)."""
        if self._cells is None:
            self._cells = encode_cells(self._logodds, self._observed, self.config.clamp)
        return self._cells

    def known_area(self) -> Rect:
        """Bounding box of observed cells; empty when nothing is observed."""
        rows = np.flatnonzero(self._observed.any(axis=1))
        if len(rows) == 0:
            return Rect(0.0, 0.0, 0.0, 0.0)
        cols = np.flatnonzero(self._observed.any(axis=0))
        res = self.spec.resolution
        return Rect(
            float(self.spec.origin_x + cols[0] * res),
            float(self.spec.origin_y + rows[0] * res),
            float((cols[-1] - cols[0] + 1) * res),
            float((rows[-1] - rows[0] + 1) * res),
        )

    def region(self, area: Rect | None = None) -> MapRegion:
        """The cells overlapping ``area`` (default: the known area), cell-aligned."""
        area = self.known_area() if area is None else area
        window = None if area.is_empty else self.spec.window(area)
        res = self.spec.resolution
        if window is None:
            return MapRegion(area.x, area.y, res, np.zeros((0, 0), dtype=np.uint8))
        rows, cols = window
        return MapRegion(
            self.spec.origin_x + cols.start * res,
            self.spec.origin_y + rows.start * res,
            res,
            self.cells()[window].copy(),
        )

    def load(self, region: MapRegion) -> None:
        """Replace the map with ``region`` (same resolution; cells outside the grid dropped)."""
        res = self.spec.resolution
        if abs(region.resolution - res) > 1e-6:
            raise ValueError(f"map resolution {region.resolution} differs from {res}")
        self.clear()
        col0 = round((region.origin_x - self.spec.origin_x) / res)
        row0 = round((region.origin_y - self.spec.origin_y) / res)
        r0, c0 = max(0, row0), max(0, col0)
        r1 = min(self.spec.height, row0 + region.height)
        c1 = min(self.spec.width, col0 + region.width)
        if r1 > r0 and c1 > c0:
            logodds, observed = decode_cells(
                region.cells[r0 - row0 : r1 - row0, c0 - col0 : c1 - col0], self.config.clamp
            )
            self._logodds[r0:r1, c0:c1] = logodds
            self._observed[r0:r1, c0:c1] = observed
        self._changed()

    def _flat(self, ix: np.ndarray, iy: np.ndarray) -> np.ndarray:
        inside = (ix >= 0) & (ix < self.spec.width) & (iy >= 0) & (iy < self.spec.height)
        return np.unique(iy[inside] * self.spec.width + ix[inside])

    def _changed(self) -> None:
        self._cells = None
        self.revision += 1

"""Ray casting on the true occupancy grid: the 360-beam lidar (and, via the same caster, the
sonars).

All rays are marched together: sample points at half-cell steps along every ray form one
``(rays, steps)`` array, a single fancy-index finds solid samples, and ``argmax`` gives each
ray's first hit. A few vectorised bisection rounds between the last free and the first solid
sample then place the hit within millimetres of the cell boundary.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import Pose2D
from ..planning.grid import GridSpec

_BISECTIONS = 5


class RayCaster:
    """Casts rays against a fixed solid mask.

    The mask is stored with a non-solid border wider than the longest ray, so sample indices
    never need clipping or bounds masks: outside the map simply reads "not solid".
    """

    def __init__(
        self,
        spec: GridSpec,
        solid: np.ndarray,
        max_reach: float = 15.0,
        step_fraction: float = 0.5,
    ) -> None:
        self._spec = spec
        self._pad = math.ceil(max_reach / spec.resolution) + 2
        self._max_reach = max_reach
        padded = np.pad(np.asarray(solid, dtype=bool), self._pad)
        self._width = padded.shape[1]
        self._solid = np.ascontiguousarray(padded).ravel()
        self._step = spec.resolution * step_fraction

    def cast(
        self, ox: np.ndarray | float, oy: np.ndarray | float, angles: np.ndarray, max_range: float
    ) -> np.ndarray:
        """Distance from each origin along each map-frame angle to the first solid cell, or
        ``inf`` when nothing solid lies within ``max_range``. Origins must lie on the map."""
        if max_range > self._max_reach:
            raise ValueError(f"max_range {max_range} exceeds the caster's reach")
        spec = self._spec
        angles = np.asarray(angles, dtype=np.float64)
        n = angles.shape[0]
        inv = 1.0 / spec.resolution
        ox = np.broadcast_to(np.asarray(ox, dtype=np.float64), (n,))
        oy = np.broadcast_to(np.asarray(oy, dtype=np.float64), (n,))
        gx = np.clip((ox - spec.origin_x) * inv, 0.0, spec.width) + self._pad
        gy = np.clip((oy - spec.origin_y) * inv, 0.0, spec.height) + self._pad
        gx, gy = gx.astype(np.float32), gy.astype(np.float32)
        dx = (np.cos(angles) * inv).astype(np.float32)
        dy = (np.sin(angles) * inv).astype(np.float32)
        steps = math.ceil(max_range / self._step)
        t = np.arange(1, steps + 1, dtype=np.float32) * np.float32(self._step)
        hit = self._solid_at(gx[:, None] + dx[:, None] * t, gy[:, None] + dy[:, None] * t)
        first = hit.argmax(axis=1)
        rows = np.arange(n)
        has_hit = hit[rows, first]
        hi = t[first]
        lo = np.where(first > 0, t[np.maximum(first - 1, 0)], np.float32(0.0))
        for _ in range(_BISECTIONS):
            mid = (lo + hi) * np.float32(0.5)
            solid = self._solid_at(gx + dx * mid, gy + dy * mid)
            hi = np.where(solid, mid, hi)
            lo = np.where(solid, lo, mid)
        return np.where(has_hit & (hi <= max_range), hi, np.inf).astype(np.float64)

    def _solid_at(self, fx: np.ndarray, fy: np.ndarray) -> np.ndarray:
        """Whether padded fractional cell coordinates fall in a solid cell."""
        return self._solid[fy.astype(np.int32) * self._width + fx.astype(np.int32)]


@dataclass(frozen=True, slots=True)
class LidarConfig:
    """A 2D lidar at the robot centre, beams evenly spaced from -pi (ascending)."""

    beams: int = 360
    max_range: float = 12.0
    min_range: float = 0.15
    noise_std: float = 0.01


class Lidar:
    """Noisy lidar frames from the true pose."""

    def __init__(self, caster: RayCaster, config: LidarConfig, rng: np.random.Generator) -> None:
        self._caster = caster
        self.config = config
        self._rng = rng
        step = 2.0 * math.pi / config.beams
        self.angles = (-math.pi + np.arange(config.beams) * step).astype(np.float64)
        self.angles.flags.writeable = False  # shared by every LaserScan handed out

    def measure(self, pose: Pose2D) -> np.ndarray:
        """Ranges for every beam (``inf`` = no return). Noise is drawn for every beam on every
        frame so the random stream, and therefore the run, only depends on the seed."""
        cfg = self.config
        true = self._caster.cast(pose.x, pose.y, self.angles + pose.yaw, cfg.max_range)
        noisy = true + self._rng.normal(0.0, cfg.noise_std, true.shape)
        valid = np.isfinite(true) & (noisy >= cfg.min_range) & (noisy <= cfg.max_range)
        return np.where(valid, noisy, np.inf)

"""Scan matching on a grid map: where a lidar scan fits, and how well.

A likelihood field of the map (``exp(-d²/2σ²)`` of the distance to the nearest obstacle)
scores a scan's endpoints projected at a pose (:class:`LikelihoodField`); a pose search scores
the scan at every free position of an area on a 0.2 m grid and every 5° of heading against a
blurred field, then refines the best candidates twice on finer grids with the sharp field
(:class:`RelocalizationSearch`, advanced in bounded slices). The simulator localizes with it
(:mod:`hitrobot_server.robot.sim.localization`), and the nodes refine a relocalization guess of
any robot with it (:mod:`hitrobot_server.robot.relocalization`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import Pose2D, Rect
from .geometry import wrap_angle
from .grid import GridSpec


@dataclass(frozen=True, slots=True)
class LocalizationConfig:
    sigma: float = 0.08
    coarse_sigma: float = 0.25
    smoothing: float = 0.5
    track_distance: float = 0.5
    track_angle: float = 0.35
    track_time_constant: float = 0.5
    drift_per_metre: float = 0.02
    drift_per_radian: float = 0.01
    match_points: int = 90
    coarse_step: float = 0.2
    coarse_yaw_step: float = math.radians(5.0)
    accept_score: float = 0.75


class LikelihoodField:
    """Per-cell likelihood that a scan endpoint belongs there, at two blur levels.

    The fields are stored with a zero border wide enough for any lidar point, so the grid
    search can index them without bounds checks.
    """

    PAD = 300
    """Border width in cells (15 m at 0.05 m/cell, beyond the lidar's range)."""

    def __init__(self, spec: GridSpec, clearance: np.ndarray, config: LocalizationConfig) -> None:
        self.spec = spec
        d2 = clearance.astype(np.float32) ** 2
        pad = self.PAD
        self._fine = np.pad(np.exp(-d2 / (2.0 * config.sigma**2)), pad)
        self._coarse = np.pad(np.exp(-d2 / (2.0 * config.coarse_sigma**2)), pad)
        self._padded_width = spec.width + 2 * pad

    def score(self, points: np.ndarray, poses: np.ndarray) -> np.ndarray:
        """Mean sharp likelihood of robot-frame ``points (n, 2)`` at each pose ``(m, 3)``."""
        spec = self.spec
        c = np.cos(poses[:, 2])[:, None]
        s = np.sin(poses[:, 2])[:, None]
        px, py = points[:, 0][None, :], points[:, 1][None, :]
        x = poses[:, 0][:, None] + c * px - s * py
        y = poses[:, 1][:, None] + s * px + c * py
        inv = 1.0 / spec.resolution
        limit_x = spec.width + self.PAD - 1
        limit_y = spec.height + self.PAD - 1
        ix = np.clip(np.floor((x - spec.origin_x) * inv), -self.PAD, limit_x).astype(np.int64)
        iy = np.clip(np.floor((y - spec.origin_y) * inv), -self.PAD, limit_y).astype(np.int64)
        return self._fine[iy + self.PAD, ix + self.PAD].mean(axis=1)

    def score_cells(
        self, points: np.ndarray, rows: np.ndarray, cols: np.ndarray, yaw: float
    ) -> np.ndarray:
        """Coarse scores of ``points`` at one heading for robots at the centres of many cells.

        With the robot on a cell centre, each rotated point lands a fixed whole number of cells
        away, so one integer offset per point serves every position: a single gather.
        """
        inv = 1.0 / self.spec.resolution
        c, s = math.cos(yaw), math.sin(yaw)
        dx = np.floor(0.5 + (c * points[:, 0] - s * points[:, 1]) * inv).astype(np.int64)
        dy = np.floor(0.5 + (s * points[:, 0] + c * points[:, 1]) * inv).astype(np.int64)
        dx = np.clip(dx, -self.PAD, self.PAD)
        dy = np.clip(dy, -self.PAD, self.PAD)
        width = self._padded_width
        base = (rows + self.PAD) * width + (cols + self.PAD)
        flat = self._coarse.reshape(-1)
        return flat[base[:, None] + (dy * width + dx)[None, :]].mean(axis=1)


def scan_points(angles: np.ndarray, ranges: np.ndarray, limit: int) -> np.ndarray:
    """Robot-frame endpoints of the valid beams, evenly thinned to at most ``limit``."""
    valid = np.flatnonzero(np.isfinite(ranges))
    if len(valid) > limit:
        valid = valid[np.linspace(0, len(valid) - 1, limit).astype(int)]
    r, a = ranges[valid], angles[valid]
    return np.stack((r * np.cos(a), r * np.sin(a)), axis=1)


class RelocalizationSearch:
    """A global or area-bounded pose search for one scan, advanced in bounded slices."""

    def __init__(
        self,
        field: LikelihoodField,
        points: np.ndarray,
        area: Rect | None,
        free: np.ndarray,
        config: LocalizationConfig,
        yaw_window: tuple[float, float] | None = None,
    ) -> None:
        """``yaw_window`` = (centre, half width) confines the headings searched (all when
        ``None``)."""
        self.done = False
        self.pose: Pose2D | None = None
        self.best: Pose2D | None = None
        self.score = 0.0
        self._field = field
        self._points = points
        self._config = config
        spec = field.spec
        area = spec.extent() if area is None or area.is_empty else area
        window = spec.window(area)
        stride = max(1, round(config.coarse_step / spec.resolution))
        rows = cols = np.zeros(0, dtype=np.int64)
        if window is not None and len(points) > 0:
            rows, cols = np.nonzero(free[window][::stride, ::stride])
            rows = rows * stride + window[0].start
            cols = cols * stride + window[1].start
        self._rows, self._cols = rows, cols
        self._positions = np.stack(spec.center(cols, rows), axis=1).reshape(-1, 2)
        if yaw_window is None:
            count = round(2.0 * math.pi / config.coarse_yaw_step)
            self._yaws = -math.pi + np.arange(count) * (2.0 * math.pi / count)
        else:
            centre, half = yaw_window
            steps = max(0, math.ceil(half / config.coarse_yaw_step))
            self._yaws = centre + np.arange(-steps, steps + 1) * config.coarse_yaw_step
        self._next_yaw = 0
        self._best = np.zeros((0, 4))
        if len(rows) == 0:
            self.done = True

    def advance(self, budget: int) -> bool:
        """Score about ``budget`` point lookups worth of candidates (at least one heading);
        True once finished (then :attr:`pose` is the accepted match, or ``None``;
        :attr:`best` is the best candidate whatever its :attr:`score`)."""
        if self.done:
            return True
        per_yaw = max(1, len(self._positions) * len(self._points))
        count = max(1, budget // per_yaw)
        for _ in range(count):
            if self._next_yaw >= len(self._yaws):
                break
            yaw = self._yaws[self._next_yaw]
            self._next_yaw += 1
            poses = np.column_stack((self._positions, np.full(len(self._positions), yaw)))
            scores = self._field.score_cells(self._points, self._rows, self._cols, yaw)
            keep = np.argsort(scores)[-8:]
            scored = np.column_stack((poses[keep], scores[keep]))
            merged = np.concatenate((self._best, scored))
            self._best = merged[np.argsort(merged[:, 3])[-8:]]
        if self._next_yaw >= len(self._yaws):
            self._refine()
            self.done = True
        return self.done

    def _refine(self) -> None:
        """Two local grid refinements of the best coarse candidates with the sharp field."""
        best_pose, best_score = None, -1.0
        for x, y, yaw, _ in self._best:
            pose = np.array([x, y, yaw])
            for step, yaw_step in ((0.05, math.radians(1.0)), (0.01, math.radians(0.25))):
                offsets = np.arange(-4, 5)
                gx, gy, gt = np.meshgrid(offsets * step, offsets * step, offsets * yaw_step)
                poses = pose + np.column_stack((gx.ravel(), gy.ravel(), gt.ravel()))
                scores = self._field.score(self._points, poses)
                pose = poses[int(np.argmax(scores))]
                score = float(scores.max())
            if score > best_score:
                best_pose, best_score = pose, score
        self.score = max(best_score, 0.0)
        if best_pose is not None:
            x, y, yaw = (float(v) for v in best_pose)
            self.best = Pose2D(x, y, wrap_angle(yaw))
            if best_score >= self._config.accept_score:
                self.pose = self.best

"""Pure-pursuit path following with a precise final approach and a final turn.

The follower steers towards a point one lookahead distance further along the path (the arc
through that point gives the curvature), turns in place when the point is far off the nose, and
slows down on a profile that can stop within the acceleration limit. Within the lookahead of the
end it steers at the end point itself, whose arc passes exactly through it, so tolerances of a
few centimetres are reachable without orbiting.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..model import Pose2D
from ..planning.geometry import wrap_angle
from ..planning.search import DEFAULT_TOLERANCE
from .kinematics import DriveLimits

YAW_TOLERANCE = 0.02
"""Final-heading tolerance (rad) the follower aims for (WITH_YAW promises 0.05)."""


@dataclass(frozen=True, slots=True)
class FollowerConfig:
    lookahead: float = 0.5
    rotate_in_place: float = 0.35
    min_speed: float = 0.04
    min_turn_speed: float = 0.15
    brake_fraction: float = 0.6


def turn_command(error: float, max_angular: float, accel: float, config: FollowerConfig) -> float:
    """Angular velocity towards a heading ``error`` on a profile that can stop in time."""
    speed = math.sqrt(2.0 * config.brake_fraction * accel * abs(error))
    return math.copysign(max(config.min_turn_speed, min(max_angular, speed)), error)


class PathFollower:
    """Follows one polyline; :attr:`done` once at the end (and turned, if a yaw was asked)."""

    def __init__(
        self,
        path: Sequence[tuple[float, float]],
        limits: DriveLimits,
        *,
        speed_ratio: float = 1.0,
        tolerance: float = DEFAULT_TOLERANCE,
        final_yaw: float | None = None,
        config: FollowerConfig | None = None,
    ) -> None:
        self._points = np.asarray(path, dtype=np.float64).reshape(-1, 2)
        self._limits = limits
        self._ratio = speed_ratio
        self._tolerance = tolerance
        self._final_yaw = final_yaw
        self._config = config or FollowerConfig()
        self._segment = 0
        self.arrived = False
        self.done = False

    @property
    def goal(self) -> tuple[float, float]:
        x, y = self._points[-1]
        return float(x), float(y)

    def command(self, pose: Pose2D) -> tuple[float, float]:
        """Velocity command (linear, angular) for the current believed pose."""
        lim, cfg = self._limits, self._config
        max_angular = lim.max_angular * self._ratio
        gx, gy = self.goal
        if not self.arrived and math.hypot(gx - pose.x, gy - pose.y) < self._tolerance:
            self.arrived = True
        if self.arrived:
            if self._final_yaw is None:
                self.done = True
                return 0.0, 0.0
            error = wrap_angle(self._final_yaw - pose.yaw)
            if abs(error) < YAW_TOLERANCE:
                self.done = True
                return 0.0, 0.0
            return 0.0, turn_command(error, max_angular, lim.angular_accel, cfg)

        tx, ty, remaining = self._target(pose)
        alpha = wrap_angle(math.atan2(ty - pose.y, tx - pose.x) - pose.yaw)
        if abs(alpha) > cfg.rotate_in_place:
            return 0.0, turn_command(alpha, max_angular, lim.angular_accel, cfg)
        brake = math.sqrt(2.0 * cfg.brake_fraction * lim.linear_accel * remaining)
        linear = min(lim.max_linear * self._ratio, brake) * max(0.3, math.cos(alpha))
        linear = max(cfg.min_speed, linear)
        distance = max(math.hypot(tx - pose.x, ty - pose.y), 1e-6)
        angular = linear * 2.0 * math.sin(alpha) / distance
        if abs(angular) > max_angular:
            linear *= max_angular / abs(angular)
            angular = math.copysign(max_angular, angular)
        return linear, angular

    def remaining_path(self, pose: Pose2D) -> list[tuple[float, float]]:
        """From the robot along the rest of the path."""
        if self.arrived:
            return []
        rest = [tuple(map(float, p)) for p in self._points[self._segment + 1 :]]
        return [(pose.x, pose.y), *rest]

    def _target(self, pose: Pose2D) -> tuple[float, float, float]:
        """Lookahead point and remaining path length from the robot's projection."""
        pts = self._points
        robot = np.array([pose.x, pose.y])
        if len(pts) == 1:
            return float(pts[0, 0]), float(pts[0, 1]), float(np.hypot(*(pts[0] - robot)))
        # Project onto the next few segments; never move backwards along the path.
        best, best_d, best_t = self._segment, math.inf, 0.0
        for k in range(self._segment, min(self._segment + 4, len(pts) - 1)):
            a, b = pts[k], pts[k + 1]
            ab = b - a
            denom = float(ab @ ab)
            t = 0.0 if denom == 0.0 else min(1.0, max(0.0, float((robot - a) @ ab) / denom))
            d = float(np.hypot(*(a + t * ab - robot)))
            if d < best_d - 1e-9:
                best, best_d, best_t = k, d, t
        self._segment = best
        lengths = np.hypot(*np.diff(pts[best:], axis=0).T)
        on_segment = (1.0 - best_t) * float(lengths[0])
        remaining = on_segment + float(lengths[1:].sum())
        ahead = self._config.lookahead
        if remaining <= ahead:
            return float(pts[-1, 0]), float(pts[-1, 1]), remaining
        start = pts[best] + best_t * (pts[best + 1] - pts[best])
        if ahead <= on_segment:
            point = start + (pts[best + 1] - start) * (ahead / on_segment)
            return float(point[0]), float(point[1]), remaining
        ahead -= on_segment
        for k in range(best + 1, len(pts) - 1):
            seg = float(lengths[k - best])
            if ahead <= seg:
                point = pts[k] + (pts[k + 1] - pts[k]) * (ahead / seg)
                return float(point[0]), float(point[1]), remaining
            ahead -= seg
        return float(pts[-1, 0]), float(pts[-1, 1]), remaining

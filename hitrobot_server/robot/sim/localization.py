"""Simulated localization: the believed pose, its quality, and relocalization by scan matching.

The robot reports ``believed = error ⊕ true`` (a map-frame transform, so a heading error
swings the whole believed trajectory, as with a real mislocalized robot). ``set_pose`` rewrites
``error``; with localization disabled ("pure odometry") the believed pose random-walks in the
robot frame as the robot moves; with it enabled, a tracker pulls a *small* pose error (under
0.5 m and 0.35 rad) back towards the truth, a stand-in for SLAM tracking, which only corrects
errors inside its capture range. A large error therefore persists until relocalization.

Quality is measured, not asserted: the current scan's endpoints are projected with the believed
pose onto a likelihood field of the reference map (``exp(-d²/2σ²)`` of the distance to the
nearest obstacle); quality is 100 × the mean likelihood, lightly smoothed, and 0 while
localization is disabled. A wrong pose makes endpoints miss walls, so quality falls by itself.

Relocalization is a real search (``RelocalizationSearch``, with the likelihood field and the
scan points, in :mod:`hitrobot_server.robot.planning.matching`). The reference map is the world
map, standing in for the map a real robot relocalizes against.
"""

from __future__ import annotations

import math

import numpy as np

from ..model import Pose2D
from ..planning.geometry import compose, inverse, wrap_angle
from ..planning.matching import LikelihoodField, LocalizationConfig


class Localizer:
    """Holds the believed-pose error and the quality estimate."""

    def __init__(
        self, field: LikelihoodField, config: LocalizationConfig, rng: np.random.Generator
    ) -> None:
        self.field = field
        self.config = config
        self._rng = rng
        self.enabled = True
        self.error = Pose2D(0.0, 0.0, 0.0)
        self.quality = 100

    def believed(self, true_pose: Pose2D) -> Pose2D:
        return compose(self.error, true_pose)

    def set_pose(self, believed: Pose2D, true_pose: Pose2D) -> None:
        """Force the believed pose (``set_pose``)."""
        self.error = compose(believed, inverse(true_pose))

    def on_motion(self, true_pose: Pose2D, distance: float, rotation: float) -> None:
        """Odometry drift while not localizing, applied in the robot frame; called every tick
        (no randoms are drawn while the robot stands still)."""
        if self.enabled or (distance == 0.0 and rotation == 0.0):
            return
        cfg = self.config
        spread = cfg.drift_per_metre * abs(distance) + cfg.drift_per_radian * abs(rotation)
        dx, dy, dyaw = self._rng.normal(0.0, spread, 3)
        believed = compose(self.believed(true_pose), Pose2D(dx, dy, dyaw))
        self.set_pose(believed, true_pose)

    def update(self, dt: float, true_pose: Pose2D, points: np.ndarray) -> None:
        """Track (pull a small pose error towards zero) and re-estimate quality from the scan
        ``points`` (robot frame)."""
        cfg = self.config
        if not self.enabled:
            self.quality = 0
            return
        believed = self.believed(true_pose)
        dx, dy = true_pose.x - believed.x, true_pose.y - believed.y
        dyaw = wrap_angle(true_pose.yaw - believed.yaw)
        if math.hypot(dx, dy) < cfg.track_distance and abs(dyaw) < cfg.track_angle:
            gain = 1.0 - math.exp(-dt / cfg.track_time_constant)
            believed = Pose2D(
                believed.x + gain * dx, believed.y + gain * dy, believed.yaw + gain * dyaw
            )
            self.set_pose(believed, true_pose)
        if len(points) == 0:
            return
        pose = np.array([[believed.x, believed.y, believed.yaw]])
        measured = 100.0 * float(self.field.score(points, pose)[0])
        blended = cfg.smoothing * self.quality + (1.0 - cfg.smoothing) * measured
        self.quality = max(0, min(100, round(blended)))

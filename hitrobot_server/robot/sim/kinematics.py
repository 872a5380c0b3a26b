"""Differential-drive motion with speed and acceleration limits and rigid-body collisions.

The robot is a disc. Before a move is accepted, its clearance (distance from the centre to the
nearest solid cell of the *true* world) is checked: a move that would bring the disc into
contact is refused, the robot stops dead, and the caller learns the bearing of the contact so a
bumper can fire. Moves that increase clearance are always allowed, so a robot touching a wall
can still back or turn away.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from ..model import Pose2D
from ..planning.geometry import wrap_angle

_PROBE_BEARINGS = [2.0 * math.pi * k / 16 for k in range(16)]


@dataclass(frozen=True, slots=True)
class DriveLimits:
    """Chassis limits; ``radius`` is the collision disc."""

    max_linear: float = 0.7
    max_angular: float = 1.8
    linear_accel: float = 1.0
    angular_accel: float = 3.0
    radius: float = 0.2


class DiffDrive:
    """State and integration of the chassis in the true world frame."""

    def __init__(
        self, pose: Pose2D, limits: DriveLimits, clearance: Callable[[float, float], float]
    ) -> None:
        self.pose = pose
        self.limits = limits
        self.linear = 0.0
        self.angular = 0.0
        self._clearance = clearance

    def step(self, linear_cmd: float, angular_cmd: float, dt: float) -> float | None:
        """Advance ``dt`` seconds towards the commanded velocity.

        Returns ``None``, or the contact bearing relative to the heading (radians) when the move
        was refused because of a collision.
        """
        lim = self.limits
        linear_cmd = max(-lim.max_linear, min(lim.max_linear, linear_cmd))
        angular_cmd = max(-lim.max_angular, min(lim.max_angular, angular_cmd))
        dv = lim.linear_accel * dt
        dw = lim.angular_accel * dt
        self.linear += max(-dv, min(dv, linear_cmd - self.linear))
        self.angular += max(-dw, min(dw, angular_cmd - self.angular))
        if self.linear == 0.0 and self.angular == 0.0:
            return None
        moved = _integrate(self.pose, self.linear, self.angular, dt)
        new_clearance = self._clearance(moved.x, moved.y)
        if new_clearance < lim.radius and new_clearance < self._clearance(self.pose.x, self.pose.y):
            self.linear = 0.0
            self.angular = 0.0
            return self._contact_bearing(moved)
        self.pose = moved
        return None

    def _contact_bearing(self, at: Pose2D) -> float:
        """Direction of the nearest obstacle from ``at``, relative to the robot's heading."""
        probe = self.limits.radius * 0.5
        best = min(
            _PROBE_BEARINGS,
            key=lambda b: self._clearance(
                at.x + probe * math.cos(at.yaw + b), at.y + probe * math.sin(at.yaw + b)
            ),
        )
        return wrap_angle(best)


def _integrate(pose: Pose2D, linear: float, angular: float, dt: float) -> Pose2D:
    """Exact unicycle motion over ``dt`` at constant velocities (an arc, or a line)."""
    yaw = pose.yaw
    turn = angular * dt
    if abs(turn) < 1e-9:
        x = pose.x + linear * dt * math.cos(yaw)
        y = pose.y + linear * dt * math.sin(yaw)
    else:
        radius = linear / angular
        x = pose.x + radius * (math.sin(yaw + turn) - math.sin(yaw))
        y = pose.y - radius * (math.cos(yaw + turn) - math.cos(yaw))
    return Pose2D(x, y, wrap_angle(yaw + turn))

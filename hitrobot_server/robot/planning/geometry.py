"""SE(2) pose algebra used by the simulator (the map frame is the only frame it needs)."""

from __future__ import annotations

import math

import numpy as np

from ..model import Pose2D


def wrap_angle(angle: float) -> float:
    """Map an angle to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def compose(a: Pose2D, b: Pose2D) -> Pose2D:
    """``a ⊕ b``: the pose ``b`` (expressed in frame ``a``) expressed in ``a``'s parent frame."""
    c, s = math.cos(a.yaw), math.sin(a.yaw)
    return Pose2D(a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrap_angle(a.yaw + b.yaw))


def inverse(p: Pose2D) -> Pose2D:
    """The pose ``q`` with ``compose(p, q)`` equal to the identity."""
    c, s = math.cos(p.yaw), math.sin(p.yaw)
    return Pose2D(-(c * p.x + s * p.y), s * p.x - c * p.y, wrap_angle(-p.yaw))


def transform_points(pose: Pose2D, points: np.ndarray) -> np.ndarray:
    """Map ``(n, 2)`` points from the frame ``pose`` into its parent frame."""
    c, s = math.cos(pose.yaw), math.sin(pose.yaw)
    x = points[:, 0]
    y = points[:, 1]
    return np.stack((pose.x + c * x - s * y, pose.y + s * x + c * y), axis=1)

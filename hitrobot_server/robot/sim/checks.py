"""Argument checks of the simulator's requests: bad values raise ``ValueError`` (the backend
words them as :class:`~hitrobot_server.robot.backend.BackendError`)."""

from __future__ import annotations

import math

from ..model import Line, Point2D, Pose2D


def checked_pose(pose: Pose2D) -> Pose2D:
    if not all(math.isfinite(v) for v in (pose.x, pose.y, pose.yaw)):
        raise ValueError("pose must be finite")
    return pose


def checked_point(point: Point2D) -> Point2D:
    if not (math.isfinite(point.x) and math.isfinite(point.y)):
        raise ValueError("points must be finite")
    return point


def checked_line(line: Line) -> Line:
    checked_point(line.start)
    checked_point(line.end)
    return line


def checked_duration(seconds: float) -> float:
    if not (math.isfinite(seconds) and seconds > 0.0):
        raise ValueError("duration must be positive")
    return seconds


def checked_saved_robot(saved: dict) -> tuple[Pose2D, Pose2D, float, bool]:
    """A saved chassis record's true pose, believed pose, battery and localization switch;
    ``ValueError`` when it is not such a record."""
    try:
        pose = checked_pose(Pose2D(*map(float, saved["pose"])))
        believed = checked_pose(Pose2D(*map(float, saved["believed"])))
        battery = float(saved["battery"])
        localization = saved["localization"]
    except (KeyError, TypeError) as exc:
        raise ValueError(f"not a saved robot state ({exc})") from None
    if not (0.0 <= battery <= 100.0) or not isinstance(localization, bool):
        raise ValueError("battery or localization out of range")
    return pose, believed, battery, localization

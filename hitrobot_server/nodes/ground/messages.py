"""ROS messages shared by the nodes: robot model values → canonical dicts, and back.

Builders and parsers that more than one node uses live here, below every node, so no node
imports another for them. Conversions follow slamware_ros_sdk's msg_convert and its laser/map
handling so a client sees the same numbers from us as from the real node.
"""

from __future__ import annotations

import math

import numpy as np

from ...bus.clock import ros_time, wall_clock
from ...bus.names import canonical
from ...bus.services import STATUS_ABORTED, GoalOutcome
from ...bus.topics import RequestRejected
from ...robot.model import (
    BasicSensorInfo,
    BasicSensorValue,
    DeviceInfo,
    ImpactType,
    LaserScan,
    Line,
    Pose2D,
    SensorType,
)
from ..base import require_finite
from .names import SLAMWARE_NODE

TWO_PI = 2.0 * math.pi
COMPENSATED_BINS = 360

# Slamware cell byte → ROS occupancy: 0 unknown → -1, 1..127 free → 0, 128..255 occupied → 100
OCCUPANCY_LUT = np.array([-1] + [0] * 127 + [100] * 128, dtype=np.int8)


def stamp(t: float | None = None) -> dict:
    """A ROS time of ``t`` (bus-clock seconds), or of now on the server's one clock."""
    return ros_time(wall_clock() if t is None else t)


def header(frame_id: str, t: float | None = None, seq: int = 0) -> dict:
    return {"seq": seq, "stamp": stamp(t), "frame_id": frame_id}


def quaternion(yaw: float) -> dict:
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2.0), "w": math.cos(yaw / 2.0)}


def yaw_of(q: dict) -> float:
    """Yaw of a quaternion as tf::getYaw computes it; an all-zero quaternion means 0."""
    x, y, z, w = q["x"], q["y"], q["z"], q["w"]
    if x == y == z == w == 0.0:
        return 0.0
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def pose(p: Pose2D) -> dict:
    return {"position": {"x": p.x, "y": p.y, "z": 0.0}, "orientation": quaternion(p.yaw)}


def pose2d(msg: dict) -> Pose2D:
    """A geometry_msgs/Pose as the robot's planar pose (z, roll and pitch are dropped)."""
    return Pose2D(msg["position"]["x"], msg["position"]["y"], yaw_of(msg["orientation"]))


def transform(parent: str, child: str, p: Pose2D, t: float) -> dict:
    return {
        "header": header(parent, t),
        "child_frame_id": child,
        "transform": {
            "translation": {"x": p.x, "y": p.y, "z": 0.0},
            "rotation": quaternion(p.yaw),
        },
    }


def laser_scan(scan: LaserScan, frame_id: str, compensate: bool, scan_time: float,
               t: float) -> dict | None:
    """sensor_msgs/LaserScan the way the node builds it, stamped ``t`` (bus clock, not the
    backend's own stamp); None for fewer than two returns."""
    angles = np.asarray(scan.angles, dtype=np.float64)
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    valid = np.isfinite(ranges) & (ranges > 0)
    if int(valid.sum()) < 2 or len(angles) < 2:
        return None
    vr = ranges[valid]
    descending = angles[-1] < angles[0]
    if compensate:
        inc = TWO_PI / COMPENSATED_BINS
        start = math.pi if descending else -math.pi
        step = -inc if descending else inc
        offsets = (angles[valid] - start) / step
        bins = np.rint(offsets).astype(np.int64) % COMPENSATED_BINS
        deviation = np.abs(offsets - np.rint(offsets))
        order = np.lexsort((deviation, bins))  # per bin, the closest angle first
        first_bins, first = np.unique(bins[order], return_index=True)
        out = np.full(COMPENSATED_BINS, np.inf, dtype=np.float32)
        out[first_bins] = vr[order][first]
        angle_min, angle_max, increment = start, start + step * (COMPENSATED_BINS - 1), step
        count = COMPENSATED_BINS
    else:
        out = np.where(valid, ranges, np.inf).astype(np.float32)
        angle_min, angle_max = float(angles[0]), float(angles[-1])
        count = len(out)
        increment = (angle_max - angle_min) / (count - 1)
    return {
        "header": header(frame_id, t),
        "angle_min": float(angle_min),
        "angle_max": float(angle_max),
        "angle_increment": float(increment),
        "time_increment": scan_time / (count - 1),
        "scan_time": scan_time,
        "range_min": float(vr.min()),
        "range_max": float(vr.max()),
        "ranges": out,
        "intensities": [],
    }


def line(ln: Line) -> dict:
    return {"id": ln.id, "start": {"x": ln.start.x, "y": ln.start.y},
            "end": {"x": ln.end.x, "y": ln.end.y}}


def sensor_info(info: BasicSensorInfo) -> dict:
    return {
        "id": info.id,
        "sensor_type": {"type": int(info.sensor_type)},
        "impact_type": {"type": int(info.impact_type)},
        "install_pose": pose(info.install_pose),
        "refresh_freq": float(info.refresh_freq),
    }


def sensor_value(info: BasicSensorInfo, value: BasicSensorValue) -> dict:
    """The node's ``is_in_impact`` rule: digital sensors are triggered at (near) zero, analog
    sonars always report, anything else never is."""
    if info.impact_type == ImpactType.DIGITAL:
        impact = abs(value.value) < np.finfo(np.float32).eps
    else:
        impact = info.impact_type == ImpactType.ANALOG and info.sensor_type == SensorType.SONAR
    return {"info": sensor_info(info), "value": {"is_in_impact": bool(impact),
                                                 "value": float(value.value)}}


def device_info(info: DeviceInfo) -> dict:
    return {
        "device_id": info.device_id,
        "model_id": info.model_id,
        "model_name": info.model_name,
        "manufacturer_id": info.manufacturer_id,
        "manufacturer_name": info.manufacturer_name,
        "hardware_version": info.hardware_version,
        "software_version": info.software_version,
        "sdp_version": info.sdp_version,
        "sdk_version": info.sdk_version,
    }


# ------------------------------------------------------------------ names
def slamware_topic(name: str) -> str:
    """A Slamware parameter's topic name: relative names live under the node (``~``),
    absolute ones stay as given."""
    return canonical(name) if name.startswith("/") else f"{SLAMWARE_NODE}/{name}"


def map_frames(map_frame: str) -> frozenset[str]:
    """Frame ids that name the map frame: empty (unset), ``map``, ``/map`` and the node's own."""
    bare = map_frame.lstrip("/")
    return frozenset({"", "map", "/map", bare, f"/{bare}"})


# ------------------------------------------------------------------ poses and goals
def pose2d_of(pose: dict, path: str) -> Pose2D:
    """A validated geometry_msgs/Pose as the robot's planar pose (all-zero quaternion = yaw 0)."""
    p, q = pose["position"], pose["orientation"]
    require_finite(f"{path}.position", p["x"], p["y"], p["z"])
    require_finite(f"{path}.orientation", q["x"], q["y"], q["z"], q["w"])
    return Pose2D(float(p["x"]), float(p["y"]), yaw_of(q))


def unit_pose2d_of(pose: dict, path: str) -> Pose2D:
    """:func:`pose2d_of` for a pose that must name a rotation: a zero quaternion, or one whose
    length is not a finite, positive number, is refused instead of read as yaw 0."""
    planar = pose2d_of(pose, path)
    q = pose["orientation"]
    length = math.hypot(float(q["x"]), float(q["y"]), float(q["z"]), float(q["w"]))
    if not math.isfinite(length) or length < 1e-6:
        raise RequestRejected(f"field '{path}.orientation' is not a rotation "
                              "(a zero or non-normalisable quaternion)")
    return planar


class GoalRejected(Exception):
    """The goal cannot run at all; the text is the reason."""


def rejected(reason: str) -> GoalOutcome:
    return GoalOutcome(STATUS_ABORTED, reason, False)


def pose_stamped(pose_: Pose2D, frame: str, t: float | None = None) -> dict:
    return {"header": header(frame, t), "pose": pose(pose_)}


def check_frame(frames: frozenset[str], header_: dict, path: str) -> None:
    frame = header_["frame_id"]
    if frame not in frames:
        raise GoalRejected(f"field '{path}.frame_id': '{frame}' is not the map frame")


def goal_pose(frames: frozenset[str], stamped: dict, path: str) -> Pose2D:
    """A validated PoseStamped in the map frame as a planar pose."""
    check_frame(frames, stamped["header"], f"{path}.header")
    try:
        return pose2d_of(stamped["pose"], f"{path}.pose")
    except RequestRejected as exc:
        raise GoalRejected(str(exc)) from None


# ------------------------------------------------------------------ maps
def occupancy_grid(grid, frame: str, now: float) -> dict:
    """A nav_msgs/OccupancyGrid of ``grid`` (origin, resolution, width, height, int8 data)."""
    return {
        "header": header(frame, now),
        "info": {
            "map_load_time": stamp(now),
            "resolution": grid.resolution,
            "width": grid.width,
            "height": grid.height,
            "origin": pose(Pose2D(grid.origin_x, grid.origin_y, 0.0)),
        },
        "data": grid.data.ravel(),
    }

"""Point clouds: ``/cloud_registered``, ``/merged_points`` and ``/downsampled_points``.

The pure part builds ``sensor_msgs/PointCloud2`` messages and down-samples clouds on a voxel
grid (numpy only); :class:`PointCloudNode` publishes the three topics from the robot's lidar.

Every cloud has the same layout: fields ``x``, ``y``, ``z``, ``intensity``, each ``FLOAT32``
(datatype 7, count 1) at offsets 0, 4, 8, 12; ``point_step`` 16, little-endian
(``is_bigendian`` false), one row (``height`` 1, ``width`` = number of points), ``is_dense``
true (no NaN points). ``data`` is ``uint8[]``, so it travels as base64 text in JSON (raw bytes
in CBOR). All points are in the map frame.

What each topic holds:

* ``/cloud_registered`` -- the current lidar frame registered into the map frame with the pose
  the robot believed when it was taken (what a LIO system's registered cloud is), at the lidar
  height ``LIDAR_HEIGHT``. Published when a new frame is there, at most every ``cloud_period``.
* ``/merged_points`` -- the robot has one 2-D lidar, the real one several solid-state lidars
  merged by ``pointcloud_accumulator_node``. We simulate that openly: the last
  ``accumulate_scans`` frames accumulated in the map frame, each return repeated at the
  ``MERGED_HEIGHTS`` rows the extra lidars would add. The world is a 2-D map, so an obstacle
  is seen as a vertical prism at every row; points from tables and the like are therefore at
  the wrong height above their legs. Published every ``merged_period``.
* ``/downsampled_points`` -- ``/merged_points`` through a voxel grid of ``leaf_size`` metres
  (PCL VoxelGrid semantics: one point per occupied voxel, the centroid of its points,
  intensity averaged), published with it.

Intensity: the simulated lidar has no reflectivity model, so every point carries
``INTENSITY`` (a real robot's REST scan has none either).

Parameters (bus parameters under ``/pointcloud_accumulator_node/``, read on every publish so
rosapi ``set_param`` takes effect at once): ``leaf_size`` (0.1 m), ``accumulate_scans`` (5),
``merged_period`` (0.5 s), ``cloud_period`` (0.1 s). Nothing is computed while a topic has no
subscriber.
"""

from __future__ import annotations

import base64
import logging
import math
import time
from collections import deque

import numpy as np

from ..bus.core import Bus
from ..robot.backend import Link, SensorBackend
from ..robot.model import LaserScan
from .base import RobotNode
from .ground import messages as m
from .ground.pacing import Pace

log = logging.getLogger(__name__)

NODE_NAME = "/pointcloud_accumulator_node"
CLOUD_TOPIC = "/cloud_registered"
MERGED_TOPIC = "/merged_points"
DOWNSAMPLED_TOPIC = "/downsampled_points"

FLOAT32 = 7  # sensor_msgs/PointField.FLOAT32
FIELD_NAMES = ("x", "y", "z", "intensity")
POINT_STEP = 16
POINT_DTYPE = np.dtype([(n, "<f4") for n in FIELD_NAMES])

LIDAR_HEIGHT = 0.2
"""Height (m) of the lidar above the floor: the z of ``/cloud_registered``."""
MERGED_HEIGHTS = (0.2, 0.5, 0.8)
"""Rows (m) of the simulated multi-lidar cloud: the 2-D lidar plus two more scan lines."""
INTENSITY = 100.0
"""Every simulated point's intensity (no reflectivity model)."""

DEFAULTS = {
    "leaf_size": 0.1,
    "accumulate_scans": 5,
    "merged_period": 0.5,
    "cloud_period": 0.1,
}
TICK = 0.05
"""Seconds between looks at the lidar; publishing follows the periods above."""


# ------------------------------------------------------------------ pure helpers
def point_fields() -> list[dict]:
    return [{"name": n, "offset": 4 * i, "datatype": FLOAT32, "count": 1}
            for i, n in enumerate(FIELD_NAMES)]


def pack_points(points: np.ndarray) -> bytes:
    """``points`` (N×3 xyz or N×4 xyz+intensity) as little-endian float32 records."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] not in (3, 4):
        raise ValueError("points must be an N×3 or N×4 array")
    out = np.zeros(len(pts), dtype=POINT_DTYPE)
    out["x"], out["y"], out["z"] = pts[:, 0], pts[:, 1], pts[:, 2]
    out["intensity"] = pts[:, 3] if pts.shape[1] == 4 else 0.0
    return out.tobytes()


def point_cloud2(points: np.ndarray, frame_id: str, stamp: float | None = None) -> dict:
    """A canonical sensor_msgs/PointCloud2 (one row, x/y/z/intensity float32) of ``points``
    (N×3 or N×4); non-finite points are dropped, so the cloud is dense."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.size == 0:
        pts = pts.reshape(0, 4)
    if pts.ndim != 2:
        raise ValueError("points must be an N×3 or N×4 array")
    pts = pts[np.isfinite(pts).all(axis=1)]
    data = pack_points(pts)
    return {
        "header": m.header(frame_id, stamp),
        "height": 1,
        "width": len(pts),
        "fields": point_fields(),
        "is_bigendian": False,
        "point_step": POINT_STEP,
        "row_step": POINT_STEP * len(pts),
        "data": data,
        "is_dense": True,
    }


def unpack_points(msg: dict) -> np.ndarray:
    """N×4 float64 (x, y, z, intensity) from a PointCloud2 in our layout (``data`` as bytes,
    base64 text or a list of ints)."""
    data = msg["data"]
    if isinstance(data, str):
        data = base64.b64decode(data)
    elif isinstance(data, list):
        data = bytes(data)
    offsets = {f["name"]: f["offset"] for f in msg["fields"]}
    dtype = np.dtype({"names": list(FIELD_NAMES), "formats": [">f4" if msg["is_bigendian"]
                                                              else "<f4"] * 4,
                      "offsets": [offsets[n] for n in FIELD_NAMES],
                      "itemsize": msg["point_step"]})
    rec = np.frombuffer(bytes(data), dtype=dtype, count=msg["width"] * msg["height"])
    return np.stack([rec[n].astype(np.float64) for n in FIELD_NAMES], axis=1)


def voxel_downsample(points: np.ndarray, leaf_size: float) -> np.ndarray:
    """One point per occupied ``leaf_size`` cube: the centroid of the points in it (every
    column averaged, so intensity too). Non-finite points are dropped; output rows are
    ordered by voxel index."""
    if not (leaf_size > 0.0 and math.isfinite(leaf_size)):
        raise ValueError("leaf_size must be a positive number")
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] < 3:
        raise ValueError("points must be an N×3 (or wider) array")
    pts = pts[np.isfinite(pts).all(axis=1)]
    if len(pts) == 0:
        return pts.copy()
    keys = np.floor(pts[:, :3] / leaf_size).astype(np.int64)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    out = np.empty((len(counts), pts.shape[1]), dtype=np.float64)
    for col in range(pts.shape[1]):
        out[:, col] = np.bincount(inverse, weights=pts[:, col], minlength=len(counts)) / counts
    return out


def scan_to_map(scan: LaserScan, z: float = LIDAR_HEIGHT) -> np.ndarray:
    """The scan's returns as N×4 map-frame points (x, y, z, intensity) from its pose."""
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    angles = np.asarray(scan.angles, dtype=np.float64)
    ok = np.isfinite(ranges) & (ranges > 0.0)
    r, a = ranges[ok], angles[ok] + scan.pose.yaw
    out = np.empty((len(r), 4), dtype=np.float64)
    out[:, 0] = scan.pose.x + r * np.cos(a)
    out[:, 1] = scan.pose.y + r * np.sin(a)
    out[:, 2] = z
    out[:, 3] = INTENSITY
    return out


def extrude(points: np.ndarray, heights: tuple[float, ...] = MERGED_HEIGHTS) -> np.ndarray:
    """``points`` (N×4) repeated at each of ``heights``."""
    rows = []
    for h in heights:
        row = points.copy()
        row[:, 2] = h
        rows.append(row)
    return np.concatenate(rows) if rows else points[:0]


# ------------------------------------------------------------------ the node
class PointCloudNode(RobotNode):
    """Publishes the three clouds from the robot's lidar frames."""

    GLOBAL_NAMES = (NODE_NAME, CLOUD_TOPIC, MERGED_TOPIC, DOWNSAMPLED_TOPIC)

    def __init__(self, bus: Bus, link: Link, sensors: SensorBackend, map_frame: str = "/map"):
        super().__init__(bus, NODE_NAME, link)
        self.sensors = sensors
        self.map_frame = map_frame
        for name, value in DEFAULTS.items():
            key = f"{NODE_NAME}/{name}"
            if not bus.params.has(key):
                bus.params.set(key, value)
        for topic in (CLOUD_TOPIC, MERGED_TOPIC, DOWNSAMPLED_TOPIC):
            self.advertise(topic, "sensor_msgs/PointCloud2")
        self._scans: deque[tuple[LaserScan, float]] = deque(maxlen=64)  # with the bus time
        self._last_stamp: float | None = None
        self._next_cloud = 0.0
        self._next_merged = 0.0

    async def start(self) -> None:
        self.every(TICK, self._tick,  # a tick with no reader fetches nothing: keep-alive
                   pace=Pace(self.bus.demand, (CLOUD_TOPIC, MERGED_TOPIC, DOWNSAMPLED_TOPIC), TICK))

    def param(self, name: str, low: float, high: float) -> float:
        """A numeric parameter clamped to [low, high]; the default when unusable."""
        value = self.bus.params.get(f"{NODE_NAME}/{name}", DEFAULTS[name])
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(
                value):
            return float(DEFAULTS[name])
        return float(min(high, max(low, value)))

    def _wanted(self, *topics: str) -> bool:
        for name in topics:
            topic = self.bus.topic(name)
            if topic is not None and topic.subscribers:
                return True
        return False

    async def _tick(self) -> None:
        cloud = self._wanted(CLOUD_TOPIC)
        merged = self._wanted(MERGED_TOPIC, DOWNSAMPLED_TOPIC)
        if not (cloud or merged):
            self._scans.clear()
            return
        taken = self.bus.clock()  # the backend's own stamp orders frames, never goes out
        scan = await self.sensors.get_laser_scan()
        fresh = scan.stamp != self._last_stamp
        if fresh:
            self._last_stamp = scan.stamp
            self._scans.append((scan, taken))
        now = time.monotonic()
        if cloud and fresh and now >= self._next_cloud:
            self._next_cloud = now + self.param("cloud_period", 0.0, 60.0) - 1e-3
            self.publish(CLOUD_TOPIC, point_cloud2(scan_to_map(scan), self.map_frame,
                                                   self._scans[-1][1]))
        if merged and now >= self._next_merged:
            self._next_merged = now + self.param("merged_period", 0.05, 60.0) - 1e-3
            self._publish_merged()

    def _publish_merged(self) -> None:
        count = int(self.param("accumulate_scans", 1, 64))
        scans = list(self._scans)[-count:]
        if not scans:
            return
        points = extrude(np.concatenate([scan_to_map(s) for s, _ in scans]))
        stamp = scans[-1][1]
        self.publish(MERGED_TOPIC, point_cloud2(points, self.map_frame, stamp))
        leaf = self.param("leaf_size", 0.005, 10.0)
        self.publish(DOWNSAMPLED_TOPIC,
                     point_cloud2(voxel_downsample(points, leaf), self.map_frame, stamp))

"""Point clouds: PointCloud2 packing and voxel down-sampling (pure), and the three topics from a
real server with the simulated robot, over a real WebSocket."""

from __future__ import annotations

import base64
import math
import struct

import numpy as np
import pytest

from hitrobot_server.nodes.pointclouds import (
    INTENSITY,
    LIDAR_HEIGHT,
    MERGED_HEIGHTS,
    NODE_NAME,
    extrude,
    pack_points,
    point_cloud2,
    scan_to_map,
    unpack_points,
    voxel_downsample,
)
from hitrobot_server.robot.model import LaserScan, Pose2D
from hitrobot_server.robot.sim.world import load_world
from tests.helpers import Watcher

FIELDS = [{"name": "x", "offset": 0, "datatype": 7, "count": 1},
          {"name": "y", "offset": 4, "datatype": 7, "count": 1},
          {"name": "z", "offset": 8, "datatype": 7, "count": 1},
          {"name": "intensity", "offset": 12, "datatype": 7, "count": 1}]


# ------------------------------------------------------------------ pure
def test_point_cloud2_layout_is_little_endian_float32_records():
    pts = np.array([[1.0, -2.0, 0.5, 7.0], [3.25, 4.5, -1.0, 0.0], [np.nan, 0, 0, 0]])
    msg = point_cloud2(pts, "map", 12.5)
    assert msg["fields"] == FIELDS
    assert (msg["height"], msg["width"], msg["point_step"], msg["row_step"]) == (1, 2, 16, 32)
    assert msg["is_bigendian"] is False and msg["is_dense"] is True  # the NaN point is gone
    assert msg["header"]["frame_id"] == "map" and msg["header"]["stamp"]["secs"] == 12
    assert isinstance(msg["data"], bytes) and len(msg["data"]) == 32
    assert struct.unpack("<8f", msg["data"]) == (1.0, -2.0, 0.5, 7.0, 3.25, 4.5, -1.0, 0.0)
    back = unpack_points({**msg, "data": base64.b64encode(msg["data"]).decode()})
    assert np.array_equal(back, pts[:2])
    xyz_only = unpack_points(point_cloud2(pts[:2, :3], "map"))
    assert np.array_equal(xyz_only[:, 3], [0.0, 0.0])
    assert point_cloud2(np.empty((0, 4)), "map")["data"] == b""
    with pytest.raises(ValueError):
        pack_points(np.zeros((3, 2)))


def test_voxel_downsample_keeps_one_centroid_per_voxel():
    pts = np.array([
        [0.01, 0.01, 0.01, 10.0],
        [0.09, 0.05, 0.03, 20.0],  # same 0.1 m voxel as the first
        [0.15, 0.0, 0.0, 5.0],     # next voxel in x
        [-0.01, 0.0, 0.0, 1.0],    # negative side: its own voxel
        [np.inf, 0.0, 0.0, 1.0],   # dropped
    ])
    out = voxel_downsample(pts, 0.1)
    assert out.shape == (3, 4)
    rows = {tuple(np.round(r, 6)) for r in out}
    assert (0.05, 0.03, 0.02, 15.0) in rows
    assert (0.15, 0.0, 0.0, 5.0) in rows and (-0.01, 0.0, 0.0, 1.0) in rows
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError):
            voxel_downsample(pts, bad)
    assert voxel_downsample(np.empty((0, 3)), 0.1).shape == (0, 3)


def test_voxel_downsample_of_a_dense_cloud_is_smaller_and_close():
    rng = np.random.default_rng(1)
    pts = rng.uniform(0.0, 1.0, size=(20_000, 3))
    for leaf in (0.1, 0.25):
        out = voxel_downsample(pts, leaf)
        assert len(out) <= math.ceil(1 / leaf) ** 3 < len(pts)
        # every input point has an output point in its own voxel
        keys_in = {tuple(k) for k in np.floor(pts / leaf).astype(int)}
        keys_out = {tuple(k) for k in np.floor(out / leaf).astype(int)}
        assert keys_in == keys_out


def test_scan_points_go_to_the_map_frame_and_extrude():
    scan = LaserScan(Pose2D(1.0, 2.0, math.pi / 2), np.array([0.0, math.pi / 2, 1.0]),
                     np.array([2.0, 1.0, np.inf]), 0.0)
    pts = scan_to_map(scan)
    assert np.allclose(pts, [[1.0, 4.0, LIDAR_HEIGHT, INTENSITY],
                             [0.0, 2.0, LIDAR_HEIGHT, INTENSITY]])
    rows = extrude(pts)
    assert len(rows) == 2 * len(MERGED_HEIGHTS)
    assert sorted(set(rows[:, 2])) == sorted(MERGED_HEIGHTS)


# ------------------------------------------------------------------ over the wire
def near_solid(world, x: float, y: float, reach: float = 0.15) -> bool:
    s = world.spec
    col, row = int((x - s.origin_x) / s.resolution), int((y - s.origin_y) / s.resolution)
    k = math.ceil(reach / s.resolution)
    window = world.solid[max(0, row - k):row + k + 1, max(0, col - k):col + k + 1]
    return bool(window.any())


async def test_clouds_have_the_documented_fields_and_downsampling_shrinks(make_server):
    server = await make_server(robot="sim", sim_speed=4.0)
    w = await Watcher.open(server.port)
    try:
        for topic in ("/cloud_registered", "/merged_points", "/downsampled_points"):
            await w.subscribe(topic, "sensor_msgs/PointCloud2")
        cloud = await w.next("/cloud_registered", 5)
        await w.until(lambda: len(w.messages.get("/downsampled_points", [])) >= 3, 10,
                      "a few merged clouds")
        merged = w.latest("/merged_points")
        down = w.latest("/downsampled_points")
        world = load_world()
        for msg in (cloud, merged, down):
            assert msg["fields"] == FIELDS and msg["point_step"] == 16
            assert msg["is_bigendian"] is False and msg["height"] == 1
            assert msg["header"]["frame_id"].lstrip("/") == "map"
            assert isinstance(msg["data"], str)  # uint8[] travels as base64
            assert len(base64.b64decode(msg["data"])) == 16 * msg["width"]
        pts = unpack_points(cloud)
        assert len(pts) > 100 and np.allclose(pts[:, 2], LIDAR_HEIGHT, atol=1e-6)
        hits = sum(near_solid(world, x, y) for x, y in pts[:, :2])
        assert hits / len(pts) > 0.95  # registered into the map: on the world's walls
        mpts = unpack_points(merged)
        assert set(np.round(mpts[:, 2], 3)) == set(MERGED_HEIGHTS)
        assert merged["width"] > cloud["width"]  # several frames × several rows
        assert 0 < down["width"] < merged["width"]

        # a coarser leaf through rosapi takes effect on the next cloud
        reply = await w.call("/rosapi/set_param", {"name": f"{NODE_NAME}/leaf_size",
                                                   "value": "0.5"})
        assert reply["result"] is True
        coarse = None
        for _ in range(10):
            coarse = await w.next("/downsampled_points", 5)
            dpts = unpack_points(coarse)
            if len(dpts) and len(np.unique(np.floor(dpts[:, :3] / 0.5), axis=0)) == len(dpts):
                break
        assert coarse is not None and coarse["width"] < down["width"]
    finally:
        await w.close()

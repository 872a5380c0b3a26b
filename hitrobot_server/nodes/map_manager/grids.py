"""Occupancy grids in and out of the map manager (pure): a client's or the robot's
``nav_msgs/OccupancyGrid`` as a :class:`~.layers.Grid`, and a Grid as Slamware explore cells."""

from __future__ import annotations

import math

import numpy as np

from ...robot.model import MapRegion
from ..ground import messages as m
from .layers import Grid, LayerError

MAX_CLIENT_MAP_CELLS = 64_000_000
OCCUPIED_FROM, FREE_UP_TO = 65, 25
"""Occupancy to explore map as map_saver thresholds it: >= 65 occupied, 0..25 free."""
EXPLORE_OCCUPIED, EXPLORE_FREE, EXPLORE_UNKNOWN = 128, 127, 0


def to_explore(grid: Grid, resolution: float) -> MapRegion:
    """An occupancy grid as Slamware explore-map cells at ``resolution`` (nearest-neighbour
    resampling when the resolutions differ)."""
    data = grid.data.astype(np.int16)
    cells = np.full(data.shape, EXPLORE_UNKNOWN, dtype=np.uint8)
    cells[(data >= 0) & (data <= FREE_UP_TO)] = EXPLORE_FREE
    cells[data >= OCCUPIED_FROM] = EXPLORE_OCCUPIED
    if math.isclose(grid.resolution, resolution, rel_tol=1e-6):
        return MapRegion(grid.origin_x, grid.origin_y, resolution, cells)
    width = max(1, math.ceil(grid.width * grid.resolution / resolution - 1e-9))
    height = max(1, math.ceil(grid.height * grid.resolution / resolution - 1e-9))
    if width * height > MAX_CLIENT_MAP_CELLS:
        raise LayerError("the map is too large at the robot's resolution")
    cols = np.minimum(((np.arange(width) + 0.5) * resolution / grid.resolution).astype(int),
                      grid.width - 1)
    rows = np.minimum(((np.arange(height) + 0.5) * resolution / grid.resolution).astype(int),
                      grid.height - 1)
    return MapRegion(grid.origin_x, grid.origin_y, resolution, cells[np.ix_(rows, cols)])


def grid_of_message(msg: dict) -> Grid:
    """A nav_msgs/OccupancyGrid dict as a Grid; LayerError when it is inconsistent."""
    info = msg["info"]
    width, height, resolution = info["width"], info["height"], info["resolution"]
    if not (math.isfinite(resolution) and resolution > 0):
        raise LayerError("field 'info.resolution' must be positive")
    if width <= 0 or height <= 0:
        raise LayerError("the map is empty (width or height is 0)")
    if width * height > MAX_CLIENT_MAP_CELLS:
        raise LayerError(f"the map is too large ({width} x {height} cells)")
    origin = info["origin"]
    x, y = origin["position"]["x"], origin["position"]["y"]
    if not (math.isfinite(x) and math.isfinite(y)):
        raise LayerError("field 'info.origin.position' must be finite")
    q = origin["orientation"]
    if not all(math.isfinite(q[k]) for k in "xyzw"):
        raise LayerError("field 'info.origin.orientation' must be finite")
    if abs(m.yaw_of(q)) > 1e-3:
        raise LayerError("rotated maps (an origin with a yaw) are not supported")
    data = np.asarray(msg["data"])
    if data.size != width * height:
        raise LayerError(f"field 'data' has {data.size} cells, not width x height = "
                         f"{width * height}")
    return Grid(float(x), float(y), float(resolution),
                data.astype(np.int8).reshape(height, width))

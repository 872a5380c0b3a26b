"""The node's map copy: merging windows, growing with a margin, tiling and windows."""

from __future__ import annotations

import numpy as np

from hitrobot_server.nodes.ground.mapsync import GROW_MARGIN, MapHolder, tiles, window
from hitrobot_server.robot.model import MapRegion, Rect


def region(x: float, y: float, cells) -> MapRegion:
    return MapRegion(x, y, 0.05, np.asarray(cells, dtype=np.uint8))


def test_merge_places_windows_on_the_global_grid_and_grows_with_margin():
    h = MapHolder()
    h.reset(0.05)
    assert h.merge(region(1.0, 2.0, [[1, 2], [3, 4]]))
    assert h.cells.shape == (2, 2) and (h.col0, h.row0) == (20, 40)
    assert h.merge(region(0.9, 2.0, [[200]]))  # one cell to the left: grows with a margin
    assert h.col0 == 18 - GROW_MARGIN and h.cells.shape[1] == 2 + 2 + GROW_MARGIN
    data, ox, oy = h.occupancy()
    grid = data.reshape(h.cells.shape)
    assert grid[0, 18 - h.col0] == 100 and grid[0, 20 - h.col0] == 0 and grid[1, 21 - h.col0] == 0
    assert (ox, oy) == (h.col0 * 0.05, h.row0 * 0.05)
    assert (grid == -1).sum() == grid.size - 5  # everything not merged is unknown


def test_resolution_mismatch_is_refused():
    h = MapHolder()
    h.reset(0.05)
    assert not h.merge(MapRegion(0, 0, 0.1, np.ones((2, 2), dtype=np.uint8)))


def test_tiles_cover_the_area_and_windows_clip():
    area = Rect(-1.0, -1.0, 35.0, 20.0)
    ts = tiles(area, 16.0)
    assert len(ts) == 3 * 2
    assert sum(t.width * t.height for t in ts) == area.width * area.height
    assert window(area, 0.0, 0.0, 8.0) == Rect(-1.0, -1.0, 9.0, 9.0)
    assert window(area, 100.0, 100.0, 8.0) is None

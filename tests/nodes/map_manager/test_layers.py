"""Layer composition, mask painting and rasterising (pure)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitrobot_server.nodes.map_manager.layers import (
    BLOCKED,
    FREE,
    KINECT_LAYER,
    MASKING_LAYER,
    MAX_MASK_CELLS,
    NOT_MASKED,
    OBSTACLE,
    SICK_LAYER,
    SLAM_LAYER,
    Grid,
    LayerError,
    Mask,
    blocked_rectangles,
    compose,
    rasterize_polygon,
    scan_hits,
)

ALL_ON = {SLAM_LAYER: True, MASKING_LAYER: True, KINECT_LAYER: True, SICK_LAYER: True}


def square(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def slam_grid(width=20, height=10, res=0.1, origin=(0.0, 0.0), value=0) -> Grid:
    return Grid(origin[0], origin[1], res, np.full((height, width), value, dtype=np.int8))


def test_rasterize_square_covers_cells_whose_centres_are_inside():
    inside = rasterize_polygon((20, 20), (0.0, 0.0), 0.1, square(0.52, 0.52, 1.48, 1.48))
    rows, cols = np.nonzero(inside)
    assert (rows.min(), rows.max(), cols.min(), cols.max()) == (5, 14, 5, 14)
    assert inside.sum() == 100


def test_rasterize_triangle_is_about_half_the_square():
    inside = rasterize_polygon((40, 40), (0.0, 0.0), 0.1, [(0.0, 0.0), (4.0, 0.0), (0.0, 4.0)])
    assert abs(int(inside.sum()) - 800) < 60
    assert inside[0, 0] and not inside[39, 39]
    assert inside[0, 39] == inside[0, 1]  # row 0 is the minimum y: the long edge runs along it


def test_mask_paint_grows_and_not_masked_removes_and_trims():
    mask = Mask(0.1)
    assert mask.empty and mask.extent() is None
    mask.paint(square(1.0, 1.0, 2.0, 2.0), BLOCKED)
    mask.paint(square(5.0, 5.0, 5.5, 5.5), OBSTACLE)
    x0, y0, x1, y1 = mask.extent()
    assert x0 <= 1.0 and y0 <= 1.0 and x1 >= 5.5 and y1 >= 5.5
    assert (mask.cells == BLOCKED).sum() >= 100 and (mask.cells == OBSTACLE).sum() >= 25
    mask.paint(square(4.5, 4.5, 6.0, 6.0), NOT_MASKED)
    assert not (mask.cells == OBSTACLE).any()
    x0, y0, x1, y1 = mask.extent()
    assert x1 <= 2.2 and y1 <= 2.2  # trimmed to what is left
    mask.paint(square(0.0, 0.0, 3.0, 3.0), NOT_MASKED)
    assert mask.empty


def test_not_masked_on_an_empty_mask_is_harmless():
    mask = Mask(0.05)
    assert mask.paint(square(0, 0, 1, 1), NOT_MASKED) == 0
    assert mask.empty


@pytest.mark.parametrize("polygon, needle", [
    ([(0.0, 0.0), (1.0, 1.0)], "at least 3"),
    ([(0.0, 0.0), (1.0, 0.0), (math.nan, 1.0)], "finite"),
    ([(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)], "no area"),
    (square(0.0, 0.0, 1000.0, 1000.0), "too large"),
])
def test_bad_polygons_are_refused_and_change_nothing(polygon, needle):
    mask = Mask(0.05)
    mask.paint(square(1.0, 1.0, 2.0, 2.0), BLOCKED)
    before = (mask.col0, mask.row0, mask.cells.copy())
    with pytest.raises(LayerError, match=needle):
        mask.paint(polygon, BLOCKED)
    assert (mask.col0, mask.row0) == before[:2] and np.array_equal(mask.cells, before[2])
    assert MAX_MASK_CELLS < 1000.0 * 1000.0 / 0.05 ** 2


def test_unknown_action_is_refused():
    with pytest.raises(LayerError):
        Mask(0.05).paint(square(0, 0, 1, 1), 42)


def test_compose_paints_enabled_layers_in_order():
    slam = slam_grid()
    slam.data[0, :] = 100  # a wall along the bottom row
    masking = Mask(0.1)
    masking.paint(square(0.0, 0.0, 0.5, 0.5), FREE)  # erases part of the wall
    masking.paint(square(1.0, 0.5, 1.5, 0.9), BLOCKED)
    sick = np.array([[1.05, 0.05], [1.55, 0.55], [50.0, 50.0]])  # on the wall, free, outside
    states = {SLAM_LAYER: True, MASKING_LAYER: True, KINECT_LAYER: False, SICK_LAYER: True}
    grid = compose(slam, states, {MASKING_LAYER: masking}, {SICK_LAYER: sick})
    assert (grid.origin_x, grid.origin_y, grid.resolution) == (0.0, 0.0, 0.1)
    assert grid.data.shape == (10, 20)
    assert grid.data[0, 2] == FREE and grid.data[0, 12] == 100
    assert grid.data[7, 12] == BLOCKED
    assert grid.data[0, 10] == 100  # a lidar hit on a wall stays a wall
    assert grid.data[5, 15] == OBSTACLE  # a new obstacle is red
    # masking off: the wall is back, the blocked square gone; SLAM off: unknown base
    grid = compose(slam, {**states, MASKING_LAYER: False}, {MASKING_LAYER: masking}, {})
    assert grid.data[0, 2] == 100 and grid.data[7, 12] == 0
    grid = compose(slam, {SLAM_LAYER: False}, {}, {})
    assert (grid.data == -1).all() and grid.data.shape == (10, 20)


def test_compose_grows_to_cover_masks_and_keeps_the_slam_lattice():
    slam = slam_grid(origin=(-0.5, -0.5))
    mask = Mask(0.1)
    mask.paint(square(2.0, 2.0, 2.4, 2.4), OBSTACLE)
    grid = compose(slam, ALL_ON, {MASKING_LAYER: mask}, {})
    assert grid.origin_x == pytest.approx(-0.5) and grid.origin_y == pytest.approx(-0.5)
    assert grid.origin_y + grid.height * 0.1 >= 2.4 - 1e-9
    col = int((2.2 - grid.origin_x) / 0.1)
    row = int((2.2 - grid.origin_y) / 0.1)
    assert grid.data[row, col] == OBSTACLE
    assert grid.data[-1, 0] == -1  # the grown part outside the map is unknown
    assert compose(None, ALL_ON, {}, {}) is None
    only_mask = compose(None, ALL_ON, {MASKING_LAYER: mask}, {})
    assert only_mask is not None and (only_mask.data == OBSTACLE).sum() >= 16


def test_mask_sampled_onto_a_grid_of_another_resolution():
    mask = Mask(0.05)
    mask.paint(square(1.0, 1.0, 2.0, 2.0), BLOCKED)
    sampled = mask.sample((0.0, 0.0), 0.1, (30, 30))
    assert sampled[15, 15] == BLOCKED and sampled[5, 5] == NOT_MASKED
    assert 90 <= (sampled == BLOCKED).sum() <= 130


def test_blocked_rectangles_cover_exactly_the_blocked_cells_of_enabled_layers():
    mask = Mask(0.1)
    mask.paint(square(1.0, 1.0, 2.0, 2.0), BLOCKED)
    mask.paint(square(1.4, 1.4, 1.6, 1.6), NOT_MASKED)  # a hole
    mask.paint(square(3.0, 0.0, 3.5, 0.5), OBSTACLE)
    mask.paint(square(0.0, 3.0, 0.5, 3.5), FREE)  # FREE does not block
    rects = blocked_rectangles(ALL_ON, {MASKING_LAYER: mask})
    covered = np.zeros((60, 60), dtype=bool)
    for x0, y0, x1, y1 in rects:
        covered[round(y0 / 0.1):round(y1 / 0.1), round(x0 / 0.1):round(x1 / 0.1)] = True
    expected = np.zeros((60, 60), dtype=bool)
    h, w = mask.cells.shape
    expected[mask.row0:mask.row0 + h, mask.col0:mask.col0 + w] = np.isin(
        mask.cells, [BLOCKED, OBSTACLE])
    assert np.array_equal(covered, expected)
    assert len(rects) < 10  # runs merged into rectangles, not one per cell
    assert blocked_rectangles({MASKING_LAYER: False}, {MASKING_LAYER: mask}) == []


def test_scan_hits_projection_and_field_of_view():
    angles = np.array([0.0, math.pi / 2, math.pi, -math.pi / 2, 0.3])
    ranges = np.array([1.0, 2.0, np.inf, 3.0, 6.0])
    pose = (1.0, 2.0, math.pi / 2)
    hits = scan_hits(pose, angles, ranges)
    assert hits.shape == (4, 2)
    assert hits[0] == pytest.approx((1.0, 3.0))  # straight ahead = +y
    assert hits[1] == pytest.approx((-1.0, 2.0))
    front = scan_hits(pose, angles, ranges, fov=math.radians(57), min_range=0.5, max_range=4.0)
    assert front.shape == (1, 2) and front[0] == pytest.approx((1.0, 3.0))

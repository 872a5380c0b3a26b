import numpy as np

from hitrobot_server.robot.model import Point2D, Rect
from hitrobot_server.robot.planning.grid import (
    GridSpec,
    distance_field,
    rasterize_polygons,
    rasterize_segments,
)


def test_distance_field_is_exact_within_its_reach():
    rng = np.random.default_rng(5)
    obstacles = rng.random((40, 50)) < 0.02
    field = distance_field(obstacles, 6)
    rows, cols = np.nonzero(obstacles)
    yy, xx = np.indices(obstacles.shape)
    brute = np.sqrt(((yy[..., None] - rows) ** 2 + (xx[..., None] - cols) ** 2).min(axis=-1))
    np.testing.assert_allclose(field, np.minimum(brute, 6), atol=1e-5)


def test_segments_are_four_connected():
    spec = GridSpec(0.0, 0.0, 0.1, 20, 20)
    mask = rasterize_segments(spec, [(0.05, 0.05, 1.95, 1.55)])
    rows, cols = np.nonzero(mask)
    assert mask[0, 0] and mask[15, 19]
    # Every marked cell but the last has a 4-neighbour marked (no diagonal-only steps).
    for r, c in zip(rows, cols, strict=True):
        neighbours = [(r + 1, c), (r - 1, c), (r, c + 1), (r, c - 1)]
        assert any(0 <= a < 20 and 0 <= b < 20 and mask[a, b] for a, b in neighbours)


def test_polygons_and_windows():
    spec = GridSpec(0.0, 0.0, 0.1, 40, 30)
    triangle = [Point2D(0.5, 0.5), Point2D(3.5, 0.5), Point2D(0.5, 2.5)]
    mask = rasterize_polygons(spec, [triangle])
    assert mask[7, 7] and mask[5, 30] and mask[20, 6]  # inside, near each corner
    assert not mask[20, 30] and not mask[0, 0]  # beyond the hypotenuse, outside
    assert mask[24, 5] and not mask[5, 36]  # the top corner is in, right of x=3.5 is out
    assert spec.window(Rect(10.0, 10.0, 1.0, 1.0)) is None

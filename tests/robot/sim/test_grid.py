import numpy as np

from hitrobot_server.robot.model import Rect
from hitrobot_server.robot.sim.grid import (
    GridSpec,
    distance_field,
    rasterize_rects,
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


def test_rects_and_windows():
    spec = GridSpec(-1.0, -1.0, 0.5, 8, 6)
    mask = rasterize_rects(spec, [Rect(0.0, 0.0, 1.0, 0.5)])
    assert mask.sum() == 2 and mask[2, 2] and mask[2, 3]
    assert spec.window(Rect(10.0, 10.0, 1.0, 1.0)) is None

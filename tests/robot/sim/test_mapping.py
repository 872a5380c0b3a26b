import math

import numpy as np

from hitrobot_server.robot.model import Point2D, Pose2D, Rect
from hitrobot_server.robot.planning.grid import GridSpec
from hitrobot_server.robot.sim.mapping import ExploreMapper, decode_cells, encode_cells
from hitrobot_server.robot.sim.simulator import SimConfig, Simulator


def test_cell_encoding_follows_slamware():
    logodds = np.array([-4.0, -2.0, 0.0, 0.1, 2.0, 4.0, 1.0], dtype=np.float32)
    observed = np.array([True] * 6 + [False])
    cells = encode_cells(logodds, observed, 4.0)
    assert list(cells) == [127, 64, 1, 253, 192, 128, 0]
    back, seen = decode_cells(cells, 4.0)
    assert (seen == observed).all()
    np.testing.assert_allclose(back[:6], logodds[:6], atol=0.05)


def test_a_scan_marks_free_space_and_the_hit_cell():
    spec = GridSpec(0.0, 0.0, 0.1, 50, 50)
    mapper = ExploreMapper(spec)
    angles = np.array([0.0, math.pi / 2])
    mapper.integrate(Pose2D(1.05, 1.05, 0.0), angles, np.array([2.0, np.inf]))
    cells = mapper.cells()
    row = 10
    assert cells[row, 30] >= 128  # hit at x = 3.05
    assert 1 <= cells[row, 20] <= 127  # passed through
    assert cells[row, 40] == 0 and cells[20, 10] == 0  # beyond the hit; no-return beam
    area = mapper.known_area()
    assert area.x == 1.0 and area.width == 2.1


def test_mapping_grows_then_freezes_when_disabled(world, run_until):
    sim = Simulator(world, seed=0, config=SimConfig(prebuilt_map=False, map_update=True))

    def known():
        return int((sim.map.map_region(world.spec.extent()).cells > 0).sum())

    start = known()
    assert start > 1000  # the first scan already maps the corridor around the robot
    info = sim.actions.move_to([Point2D(15.0, 8.0)])
    assert run_until(sim, lambda: sim.actions.action(info.action_id).done, 60.0)
    grown = known()
    assert grown > start * 2
    sim.map.map_update = False
    frozen = sim.map.map_region(world.spec.extent()).cells.copy()
    info = sim.actions.move_to([Point2D(15.0, 12.0)])  # into office C: new walls in view
    assert run_until(sim, lambda: sim.actions.action(info.action_id).done, 60.0)
    assert (sim.map.map_region(world.spec.extent()).cells == frozen).all()
    sim.map.map_update = True
    sim.step(0.5)
    assert known() > grown


def test_map_agrees_with_the_world_where_observed(world, run_until):
    sim = Simulator(world, seed=0, config=SimConfig(prebuilt_map=False, map_update=True))
    sim.step(2.0)
    cells = sim.map.map_region(world.spec.extent()).cells
    occupied = cells >= 128
    free = (cells > 0) & (cells < 128)
    # Nearly every mapped-free cell is truly free; occupied cells are on or next to obstacles.
    assert world.free[free].mean() > 0.99
    assert (sim._true_field[occupied] <= 1.5).mean() > 0.95


def test_clear_map_and_regions(world):
    sim = Simulator(world, seed=0)
    region = sim.map.map_region(Rect(4.0, 7.5, 2.0, 1.0))
    assert (region.width, region.height) == (40, 20)
    assert (region.origin_x, region.origin_y) == (4.0, 7.5)
    assert (region.cells > 0).all()
    sim.map.clear_map()
    assert sim.map.known_area().is_empty
    assert sim.map.map_region().width == 0

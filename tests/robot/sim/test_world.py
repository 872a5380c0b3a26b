import math

import numpy as np
import pytest

from hitrobot_server.robot.sim.world import load_world, parse_map_yaml


def test_office_is_big_enough_and_places_robot_and_dock(world):
    extent = world.spec.extent()
    assert world.spec.resolution == pytest.approx(0.05)
    assert extent.width >= 20.0 and extent.height >= 15.0
    for pose in (world.start_pose, world.dock_pose):
        ix, iy = world.spec.cell(pose.x, pose.y)
        assert world.free[iy, ix]
    assert world.dock_pose.yaw == pytest.approx(math.pi / 2)
    assert world.unknown.any() and world.occupied.any()


def test_office_has_walls_where_the_generator_put_them(world):
    # The corridor's south wall spans y 6.85..7.0; the lobby opening x 2.5..4.5 is free.
    ix, iy = world.spec.cell(5.0, 6.9)
    assert world.occupied[iy, ix]
    ix, iy = world.spec.cell(3.5, 6.9)
    assert not world.occupied[iy, ix]


def test_image_rows_are_flipped_so_row_zero_is_min_y(tmp_path):
    pixels = np.full((4, 6), 254, dtype=np.uint8)
    pixels[0, 0] = 0  # top-left of the image: max y, min x
    pixels[3, 5] = 205  # bottom-right: min y, max x, unknown
    (tmp_path / "m.pgm").write_bytes(b"P5\n6 4\n255\n" + pixels.tobytes())
    (tmp_path / "m.yaml").write_text(
        "image: m.pgm  # comment\nresolution: 0.5\norigin: [1.0, -2.0, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n"
    )
    world = load_world(tmp_path / "m.yaml")
    assert world.spec.shape == (4, 6)
    assert world.occupied[3, 0] and world.occupied.sum() == 1
    assert world.unknown[0, 5] and world.unknown.sum() == 1
    assert world.dock_pose is None
    ix, iy = world.spec.cell(world.start_pose.x, world.start_pose.y)
    assert world.free[iy, ix]


def test_rotated_origin_is_refused(tmp_path):
    (tmp_path / "m.pgm").write_bytes(b"P5\n1 1\n255\n\xfe")
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 1\norigin: [0, 0, 0.5]\n")
    with pytest.raises(ValueError, match="rotated"):
        load_world(tmp_path / "m.yaml")


def test_yaml_subset():
    meta = parse_map_yaml("a: 1\nb: 'x # y'\nc: [1, 2.5, -3]\nd: true\n# only a comment\ne: [ ]\n")
    assert meta == {"a": 1, "b": "x # y", "c": [1, 2.5, -3], "d": True, "e": []}
    with pytest.raises(ValueError):
        parse_map_yaml("no colon here")

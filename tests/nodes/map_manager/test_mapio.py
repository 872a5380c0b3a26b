"""Map folder files: map_server YAML + PGM, masks, POIs (pure)."""

from __future__ import annotations

import io

import numpy as np
import pytest
import yaml
from PIL import Image

from hitrobot_server.nodes.map_manager import mapio
from hitrobot_server.nodes.map_manager.layers import (
    BLOCKED,
    FREE,
    MASKING_LAYER,
    OBSTACLE,
    SICK_LAYER,
    Grid,
    Mask,
)


def sample_grid() -> Grid:
    data = np.full((4, 6), -1, dtype=np.int8)
    data[0, :] = 100  # bottom row (minimum y) occupied
    data[1:3, 1:5] = 0
    data[3, 5] = 50  # neither free nor occupied: unknown in trinary
    return Grid(-1.25, 2.5, 0.05, data)


def test_map_is_map_saver_trinary_with_row_zero_at_the_top():
    map_yaml, pgm = mapio.encode_map(sample_grid())
    doc = yaml.safe_load(map_yaml)
    assert doc == {"image": "map.pgm", "resolution": 0.05, "origin": [-1.25, 2.5, 0.0],
                   "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196,
                   "mode": "trinary"}
    assert pgm.startswith(b"P5")
    image = np.asarray(Image.open(io.BytesIO(pgm)))
    assert image.shape == (4, 6) and set(np.unique(image)) == {0, 205, 254}
    assert (image[-1, :] == 0).all()  # the occupied bottom row is the last image row
    assert (image[1:3, 1:5] == 254).all() and image[0, 5] == 205


def test_map_round_trip():
    grid = sample_grid()
    back = mapio.decode_map(*mapio.encode_map(grid))
    expected = grid.data.copy()
    expected[3, 5] = -1
    assert np.array_equal(back.data, expected)
    assert (back.origin_x, back.origin_y, back.resolution) == (-1.25, 2.5, 0.05)


def test_decode_follows_map_server_rules():
    pixels = np.array([[0, 100, 210, 255]], dtype=np.uint8)
    out = io.BytesIO()
    Image.fromarray(pixels, mode="L").save(out, format="PNG")
    base = "image: m.png\nresolution: 0.1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n" \
           "free_thresh: 0.196\n"
    trinary = mapio.decode_map((base + "negate: 0\n").encode(), out.getvalue())
    assert trinary.data.tolist() == [[100, -1, 0, 0]]
    negated = mapio.decode_map((base + "negate: 1\n").encode(), out.getvalue())
    assert negated.data.tolist() == [[0, -1, 100, 100]]
    scale = mapio.decode_map((base + "negate: 0\nmode: scale\n").encode(), out.getvalue())
    assert scale.data[0, 0] == 100 and 0 < scale.data[0, 1] < 100 and scale.data[0, 3] == 0


@pytest.mark.parametrize("text, needle", [
    ("image: m.pgm\nresolution: 0\norigin: [0, 0, 0]\n", "positive"),
    ("image: m.pgm\nresolution: 0.05\norigin: [0, 0]\n", "origin"),
    ("image: ../m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n", "file name"),
    ("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nmode: fancy\n", "mode"),
    ("- a list\n", "mapping"),
    (": : :\n", "YAML"),
])
def test_bad_map_yaml(text, needle):
    _yaml, pgm = mapio.encode_map(sample_grid())
    with pytest.raises(mapio.MapFileError, match=needle):
        mapio.decode_map(text.encode(), pgm)


def test_bad_image():
    map_yaml, _pgm = mapio.encode_map(sample_grid())
    with pytest.raises(mapio.MapFileError, match="image"):
        mapio.decode_map(map_yaml, b"not an image")


def test_masks_round_trip():
    masking, sick = Mask(0.05), Mask(0.1)
    masking.paint([(0.0, 0.0), (1.0, 0.0), (1.0, 0.5), (0.0, 0.5)], BLOCKED)
    masking.paint([(0.2, 0.1), (0.4, 0.1), (0.4, 0.3), (0.2, 0.3)], FREE)
    sick.paint([(-2.0, -2.0), (-1.0, -2.0), (-1.5, -1.0)], OBSTACLE)
    files = mapio.encode_masks({MASKING_LAYER: masking, SICK_LAYER: sick, 2: Mask(0.05)})
    assert sorted(files) == ["mask_masking_layer.png", "mask_sick_layer.png", "masks.yaml"]
    doc = yaml.safe_load(files["masks.yaml"])
    assert [e["layer"] for e in doc["layers"]] == [MASKING_LAYER, SICK_LAYER]
    assert doc["values"] == {"not_masked": 205, "free": 254, "obstacle": 128, "blocked": 0}
    images = {n: files[n] for n in mapio.mask_images(files["masks.yaml"])}
    back = mapio.decode_masks(files["masks.yaml"], images)
    for layer, mask in ((MASKING_LAYER, masking), (SICK_LAYER, sick)):
        got = back[layer]
        assert (got.col0, got.row0, got.resolution) == (mask.col0, mask.row0, mask.resolution)
        assert np.array_equal(got.cells, mask.cells)
    empty = mapio.encode_masks({})
    assert mapio.decode_masks(empty["masks.yaml"], {}) == {}


def test_masks_with_foreign_pixels_are_refused():
    mask = Mask(0.05)
    mask.paint([(0.0, 0.0), (1.0, 0.0), (1.0, 0.5)], BLOCKED)
    files = mapio.encode_masks({MASKING_LAYER: mask})
    out = io.BytesIO()
    Image.fromarray(np.full((3, 3), 77, dtype=np.uint8), mode="L").save(out, format="PNG")
    with pytest.raises(mapio.MapFileError, match="pixel values"):
        mapio.decode_masks(files["masks.yaml"], {"mask_masking_layer.png": out.getvalue()})
    with pytest.raises(mapio.MapFileError, match="missing"):
        mapio.decode_masks(files["masks.yaml"], {})


def test_pois_and_robot_round_trip():
    pois = [{"type": 100, "name": "Küche", "remarks": "ä",
             "pose": {"position": {"x": 1.0, "y": 2.0, "z": 0.0},
                      "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}]
    assert mapio.decode_pois(mapio.encode_pois(pois)) == pois
    assert mapio.decode_pois(mapio.encode_pois([])) == []
    from hitrobot_server.robot.model import Line, Point2D, Pose2D

    data = mapio.encode_robot([Line(3, Point2D(0, 1), Point2D(2, 3))], [], Pose2D(1, 2, 0.5))
    assert mapio.decode_robot(data) == {"virtual_walls": [(3, 0.0, 1.0, 2.0, 3.0)],
                                        "virtual_tracks": [], "home": (1.0, 2.0, 0.5)}
    with pytest.raises(mapio.MapFileError):
        mapio.decode_robot(b"virtual_walls: [{id: 1, start: [0], end: [1, 2]}]\n")

"""The binary explore map: 36-byte header, row 0 at the minimum y, bytes passed through."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from hitrobot_server.robot.model import MapRegion, Rect
from hitrobot_server.robot.rest import mapformat, paths


def region(ox: float, oy: float, res: float, h: int, w: int, seed: int = 0) -> MapRegion:
    cells = np.random.default_rng(seed).integers(0, 256, size=(h, w), dtype=np.uint8)
    return MapRegion(ox, oy, res, cells)


def test_header_is_36_bytes_with_the_length_at_32():
    data = mapformat.encode(region(-3.25, 7.5, 0.05, 3, 5))
    assert mapformat.HEADER_SIZE == 36 and len(data) == 36 + 15
    ox, oy, w, h, res = struct.unpack_from("<ffIIf", data, 0)
    assert (ox, oy, w, h) == (-3.25, 7.5, 5, 3) and abs(res - 0.05) < 1e-8
    assert data[20:32] == bytes(12)  # reserved
    assert struct.unpack_from("<I", data, 32) == (15,)


@pytest.mark.parametrize("h,w", [(1, 1), (3, 7), (17, 5), (101, 33), (0, 0)])
def test_round_trip_with_a_non_zero_origin_and_odd_sizes(h, w):
    original = region(-12.35, 4.15, 0.05, h, w, seed=h * w)
    data = mapformat.encode(original)
    decoded = mapformat.decode(data)
    assert decoded is not None
    assert decoded.cells.shape == (h, w)
    assert np.array_equal(decoded.cells, original.cells)
    # the float32 fields read back as the decimals that were meant
    assert (decoded.origin_x, decoded.origin_y, decoded.resolution) == (-12.35, 4.15, 0.05)
    assert mapformat.encode(decoded) == data  # byte for byte


def test_rows_run_upward_and_cells_pass_through_untouched():
    cells = np.array([[0, 1, 127], [128, 200, 255]], dtype=np.uint8)  # row 0 = minimum y
    data = mapformat.encode(MapRegion(1.0, 2.0, 0.1, cells))
    assert data[36:] == bytes([0, 1, 127, 128, 200, 255])
    back = mapformat.decode(data)
    assert back.cells.tolist() == cells.tolist() and back.cells.dtype == np.uint8


def test_short_replies_mean_no_map_and_inconsistent_ones_are_errors():
    assert mapformat.decode(b"") is None
    assert mapformat.decode(bytes(35)) is None
    good = mapformat.encode(region(0.0, 0.0, 0.05, 4, 4))
    bad_length = good[:32] + struct.pack("<I", 15) + good[36:]
    with pytest.raises(mapformat.MapFormatError, match="15 data bytes"):
        mapformat.decode(bad_length)
    with pytest.raises(mapformat.MapFormatError, match="truncated"):
        mapformat.decode(good[:-1])
    zero_res = good[:16] + struct.pack("<f", 0.0) + good[20:]
    with pytest.raises(mapformat.MapFormatError, match="resolution"):
        mapformat.decode(zero_res)


def test_trailing_bytes_after_the_cells_are_ignored():
    good = mapformat.encode(region(0.0, 0.0, 0.05, 2, 3))
    assert np.array_equal(mapformat.decode(good + b"\x00\x01").cells,
                          mapformat.decode(good).cells)


async def test_the_client_decodes_the_device_map_byte_for_byte(device, client):
    import aiohttp

    sim = device.simulator
    area = Rect(3.03, 2.51, 5.12, 3.33)  # not cell-aligned: the device snaps to cells
    async with aiohttp.ClientSession() as session:
        q = {"min_x": "3.03", "min_y": "2.51", "max_x": str(3.03 + 5.12),
             "max_y": str(2.51 + 3.33)}
        async with session.get(device.url + paths.EXPLORE_MAP, params=q) as resp:
            assert resp.status == 200
            assert resp.content_type == "application/octet-stream"
            wire = await resp.read()
    got = await client.maps.get_map(area)
    expected = sim.map.map_region(area)
    assert got.cells.shape == expected.cells.shape
    assert got.width % 2 == 1 and got.height % 2 == 1
    assert np.array_equal(got.cells, expected.cells)
    assert (got.origin_x, got.origin_y, got.resolution) == (
        expected.origin_x, expected.origin_y, expected.resolution)
    assert got.origin_x != 0.0 and got.origin_y != 0.0
    assert mapformat.encode(got) == wire

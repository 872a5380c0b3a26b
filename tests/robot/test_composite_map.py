import struct
import zlib

import numpy as np
import pytest

from hitrobot_server.robot.composite_map import CompositeMap, CompositeMapError, decode, encode
from hitrobot_server.robot.model import Line, MapRegion, Point2D, Pose2D


def _sample() -> CompositeMap:
    cells = np.arange(12, dtype=np.uint8).reshape(3, 4)
    return CompositeMap(
        explore=MapRegion(-1.5, 2.25, 0.05, cells),
        walls=(Line(3, Point2D(0.0, 0.0), Point2D(1.0, 2.0)),),
        tracks=(Line(7, Point2D(-1.0, 0.5), Point2D(4.0, 0.5)),),
        home=Pose2D(3.5, 0.55, 1.25),
    )


def test_round_trip_keeps_everything():
    out = decode(encode(_sample()))
    assert out.explore is not None
    assert (out.explore.origin_x, out.explore.origin_y) == (-1.5, 2.25)
    assert out.explore.resolution == pytest.approx(0.05)
    np.testing.assert_array_equal(out.explore.cells, np.arange(12).reshape(3, 4))
    assert out.walls == _sample().walls
    assert out.tracks == _sample().tracks
    assert out.home == Pose2D(3.5, 0.55, 1.25)


def test_empty_map_round_trips():
    out = decode(encode(CompositeMap(explore=None)))
    assert out.explore is None and out.home is None and out.walls == ()


def test_header_is_documented_layout():
    data = encode(_sample())
    assert data[:4] == b"HRCM"
    assert struct.unpack_from("<HH", data, 4) == (1, 4)
    assert struct.unpack_from("<I", data, len(data) - 4)[0] == zlib.crc32(data[:-4])


def test_unknown_sections_are_skipped():
    data = encode(CompositeMap(explore=None, home=Pose2D(1.0, 2.0, 0.0)))
    body = bytearray(data[:-4])
    struct.pack_into("<H", body, 6, struct.unpack_from("<H", body, 6)[0] + 1)
    body += b"POIS" + struct.pack("<I", 3) + b"abc"
    body += struct.pack("<I", zlib.crc32(body))
    assert decode(bytes(body)).home == Pose2D(1.0, 2.0, 0.0)


@pytest.mark.parametrize(
    "mutate",
    [
        lambda d: b"XXXX" + d[4:],
        lambda d: d[:10] + bytes([d[10] ^ 0xFF]) + d[11:],
        lambda d: d[:6],
        lambda d: d[:4] + struct.pack("<H", 9) + d[6:],
    ],
    ids=["magic", "checksum", "truncated", "version"],
)
def test_corrupt_input_is_rejected(mutate):
    with pytest.raises(CompositeMapError):
        decode(mutate(encode(_sample())))

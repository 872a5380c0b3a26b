"""hitrobot's own composite-map container: what the simulator hands out as ``raw_stcm``.

This is **not** SLAMTEC's ``.stcm`` format (which is proprietary); a real robot's bytes are
passed through untouched and never parsed here. The container exists so the simulator can
round-trip a map through ``sync_get_stcm`` / ``sync_set_stcm``.

Layout, all integers and floats little-endian::

    offset  size  field
    0       4     magic b"HRCM"
    4       2     uint16 format version (currently 1)
    6       2     uint16 number of sections
    8       ...   sections, each: 4-byte ASCII tag, uint32 payload length, payload
    end-4   4     uint32 CRC-32 (zlib) of every byte before it

Sections (each at most once; readers skip tags they do not know, so later versions can add
sections such as POIs without breaking older readers):

``EXPL``  explore map: float32 origin x, float32 origin y, uint32 width, uint32 height,
          float32 resolution, then width*height uint8 cells, row 0 at the minimum y, in the
          Slamware explore encoding (0 unknown, 1-127 free, 128-255 occupied).
``WALL``  virtual walls: uint32 count, then count * (uint32 id, float32 x0, y0, x1, y1).
``TRAK``  virtual tracks: same layout as ``WALL``.
``HOME``  home dock pose: float64 x, y, yaw.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

import numpy as np

from .model import Line, MapRegion, Point2D, Pose2D

MAGIC = b"HRCM"
VERSION = 1

_HEADER = struct.Struct("<4sHH")
_SECTION = struct.Struct("<4sI")
_MAP_HEADER = struct.Struct("<ffIIf")
_LINE = struct.Struct("<Iffff")
_HOME = struct.Struct("<ddd")


class CompositeMapError(ValueError):
    """The bytes are not a valid composite map of a version this reader understands."""


@dataclass(frozen=True, slots=True, eq=False)
class CompositeMap:
    """Everything a composite map carries."""

    explore: MapRegion | None
    walls: tuple[Line, ...] = ()
    tracks: tuple[Line, ...] = ()
    home: Pose2D | None = None


def encode(cmap: CompositeMap) -> bytes:
    """Serialize ``cmap`` to the documented byte layout."""
    sections: list[tuple[bytes, bytes]] = []
    if cmap.explore is not None:
        region = cmap.explore
        cells = np.ascontiguousarray(region.cells, dtype=np.uint8)
        head = _MAP_HEADER.pack(
            region.origin_x, region.origin_y, region.width, region.height, region.resolution
        )
        sections.append((b"EXPL", head + cells.tobytes()))
    sections.append((b"WALL", _encode_lines(cmap.walls)))
    sections.append((b"TRAK", _encode_lines(cmap.tracks)))
    if cmap.home is not None:
        sections.append((b"HOME", _HOME.pack(cmap.home.x, cmap.home.y, cmap.home.yaw)))
    body = bytearray(_HEADER.pack(MAGIC, VERSION, len(sections)))
    for tag, payload in sections:
        body += _SECTION.pack(tag, len(payload)) + payload
    body += struct.pack("<I", zlib.crc32(body))
    return bytes(body)


def decode(data: bytes) -> CompositeMap:
    """Parse bytes written by :func:`encode`; raises :class:`CompositeMapError` when invalid."""
    if len(data) < _HEADER.size + 4:
        raise CompositeMapError("composite map too short")
    magic, version, count = _HEADER.unpack_from(data, 0)
    if magic != MAGIC:
        raise CompositeMapError("not a hitrobot composite map (bad magic)")
    if version != VERSION:
        raise CompositeMapError(f"unsupported composite map version {version}")
    (crc,) = struct.unpack_from("<I", data, len(data) - 4)
    if zlib.crc32(data[:-4]) != crc:
        raise CompositeMapError("composite map checksum mismatch")
    explore = home = None
    walls: tuple[Line, ...] = ()
    tracks: tuple[Line, ...] = ()
    offset = _HEADER.size
    end = len(data) - 4
    for _ in range(count):
        if offset + _SECTION.size > end:
            raise CompositeMapError("truncated section header")
        tag, length = _SECTION.unpack_from(data, offset)
        offset += _SECTION.size
        if offset + length > end:
            raise CompositeMapError(f"section {tag!r} runs past the end")
        payload = data[offset : offset + length]
        offset += length
        if tag == b"EXPL":
            explore = _decode_region(payload)
        elif tag == b"WALL":
            walls = _decode_lines(payload)
        elif tag == b"TRAK":
            tracks = _decode_lines(payload)
        elif tag == b"HOME":
            if length != _HOME.size:
                raise CompositeMapError("bad HOME section")
            home = Pose2D(*_HOME.unpack(payload))
    return CompositeMap(explore=explore, walls=walls, tracks=tracks, home=home)


def _encode_lines(lines: tuple[Line, ...]) -> bytes:
    out = bytearray(struct.pack("<I", len(lines)))
    for line in lines:
        out += _LINE.pack(line.id, line.start.x, line.start.y, line.end.x, line.end.y)
    return bytes(out)


def _decode_lines(payload: bytes) -> tuple[Line, ...]:
    if len(payload) < 4:
        raise CompositeMapError("bad line section")
    (count,) = struct.unpack_from("<I", payload, 0)
    if len(payload) != 4 + count * _LINE.size:
        raise CompositeMapError("line section length does not match its count")
    lines = []
    for i in range(count):
        lid, x0, y0, x1, y1 = _LINE.unpack_from(payload, 4 + i * _LINE.size)
        lines.append(Line(lid, Point2D(x0, y0), Point2D(x1, y1)))
    return tuple(lines)


def _decode_region(payload: bytes) -> MapRegion:
    if len(payload) < _MAP_HEADER.size:
        raise CompositeMapError("bad EXPL section")
    ox, oy, width, height, resolution = _MAP_HEADER.unpack_from(payload, 0)
    if len(payload) != _MAP_HEADER.size + width * height:
        raise CompositeMapError("explore map size does not match its dimensions")
    if not resolution > 0.0:
        raise CompositeMapError("explore map resolution must be positive")
    cells = np.frombuffer(payload, dtype=np.uint8, offset=_MAP_HEADER.size)
    return MapRegion(ox, oy, resolution, cells.reshape(height, width).copy())

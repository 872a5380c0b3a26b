"""The Slamware binary explore map (``GET /api/core/slam/v1/maps/explore``), sans I/O.

Layout, all little-endian: origin x and y (float32, metres, the lower-left corner of cell
(0, 0)), width and height (uint32, cells), resolution (float32, metres per cell), 12 reserved
bytes, then at offset 32 the byte count of the cell data (uint32, must equal width × height),
and from offset 36 one byte per cell, row-major with row 0 at the minimum y. The vendor's
prose speaks of a 32-byte header, but its own table and every known parser put the length at
32-35, so the effective header is 36 bytes.

Cell bytes are passed through untouched (0 unknown, 1-127 free, 128-255 occupied, read as a
signed byte); converting them to ROS occupancy is the node's business.
"""

from __future__ import annotations

import struct

import numpy as np

from ..model import MapRegion
from .limits import MAP_HEADER, MAX_MAP_CELLS, RESOLUTIONS

HEADER = struct.Struct("<ffIIf12xI")
HEADER_SIZE = HEADER.size  # 36: 5 fields of 4 bytes, 12 reserved, the length
assert HEADER_SIZE == MAP_HEADER
DEFAULT_RESOLUTION = 0.05
"""What a reply too short to carry a header is taken to have (the ROS node's default)."""


class MapFormatError(ValueError):
    """The bytes are not an explore map (inconsistent sizes)."""


def encode(region: MapRegion) -> bytes:
    """The wire bytes of ``region`` (reserved bytes zero)."""
    cells = np.ascontiguousarray(region.cells, dtype=np.uint8)
    if cells.ndim != 2:
        raise MapFormatError("map cells must be a 2-D array")
    height, width = cells.shape
    header = HEADER.pack(
        float(region.origin_x), float(region.origin_y), width, height,
        float(region.resolution), width * height,
    )
    return header + cells.tobytes()


def declared_size(head: bytes) -> int:
    """The bytes of the map whose first :data:`HEADER_SIZE` bytes are ``head`` (all of
    ``head`` when it is shorter: no map). Raises :class:`MapFormatError` when the header
    declares more than :data:`~.limits.MAX_MAP_CELLS` cells or disagrees with itself, so an
    absurd map is refused before its cells are read."""
    if len(head) < HEADER_SIZE:
        return len(head)
    _ox, _oy, width, height, _resolution, length = HEADER.unpack_from(head, 0)
    if length != width * height:
        raise MapFormatError(
            f"explore map header says {width}x{height} cells but {length} data bytes"
        )
    if length > MAX_MAP_CELLS:
        raise MapFormatError(f"explore map of {width}x{height} cells is over the bound of "
                             f"{MAX_MAP_CELLS} cells")
    return HEADER_SIZE + length


def decode(data: bytes) -> MapRegion | None:
    """The region in ``data``; ``None`` when the reply is too short to hold a header (the robot
    has no map yet). Raises :class:`MapFormatError` when the sizes disagree."""
    if len(data) < HEADER_SIZE:
        return None
    declared_size(data[:HEADER_SIZE])
    ox, oy, width, height, resolution, length = HEADER.unpack_from(data, 0)
    if len(data) - HEADER_SIZE < length:
        raise MapFormatError(
            f"explore map truncated: {len(data) - HEADER_SIZE} of {length} data bytes"
        )
    if not (np.isfinite(resolution) and resolution > 0.0):
        raise MapFormatError(f"explore map resolution {resolution} is not positive")
    if not RESOLUTIONS[0] <= resolution <= RESOLUTIONS[1]:
        raise MapFormatError(f"explore map resolution {resolution:g} m is outside "
                             f"{RESOLUTIONS[0]:g}-{RESOLUTIONS[1]:g} m")
    if not (np.isfinite(ox) and np.isfinite(oy)):
        raise MapFormatError("explore map origin is not finite")
    cells = np.frombuffer(data, dtype=np.uint8, count=length, offset=HEADER_SIZE)
    return MapRegion(
        _decimal(ox), _decimal(oy), _decimal(resolution),
        cells.reshape(height, width).copy(),
    )


def _decimal(value: float) -> float:
    """The shortest decimal that is the same float32 (0.05, not 0.05000000074505806), so
    resolutions and origins read as the robot meant them; re-encoding gives the same bytes."""
    single = np.float32(value)
    nice = float(np.format_float_positional(single, unique=True, trim="0"))
    return nice if np.float32(nice) == single else float(single)

"""Opening one chunk of a recording, bounded before it starts.

A chunk's ``uncompressed_size`` must be one its compressed bytes can produce (a zstd block of
128 KiB costs at least 3 bytes, an LZ4 match byte at most 255) and must fit ``--max-inflated``;
the inflation itself stops at the size the chunk claims, and a chunk whose first record is not
one (a run of zeros) is refused after its first block, so a bomb costs the time it takes to
read its headers. The records inside are read with ``struct`` straight from the bytes.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from typing import BinaryIO

import lz4.frame
import zstandard

from .schemas import RecordingError

MAX_RATIO = {"zstd": 131072 // 3 + 1, "lz4": 256, "": 1}
"""The most a byte of each compression can inflate to (an upper bound, never reached)."""
_READ = 1 << 20
_HEAD = struct.Struct("<BQ")  # a record's opcode and length
_MESSAGE = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
SCHEMA, CHANNEL, MESSAGE = 0x03, 0x04, 0x05


class Budget:
    """What is left of the bytes a replay may inflate."""

    def __init__(self, limit: int):
        self.limit = limit
        self.left = limit

    def take(self, size: int, what: str) -> None:
        if size > self.left:
            raise RecordingError(
                f"{what} would inflate to {size} bytes, over what is left of the "
                f"{self.limit // 2**20} MiB a replay may hold (--max-inflated): a "
                "decompression bomb or a recording too big to replay")
        self.left -= size


def believable(compression: str, packed: int, claimed: int) -> int:
    """The size a chunk claims to inflate to, if its compressed bytes can produce it."""
    ratio = MAX_RATIO.get(compression)
    if ratio is None:
        raise RecordingError(f"a chunk is compressed with {compression!r}, which replay "
                             "does not read (zstd, lz4 or none)")
    if claimed > max(packed, 1) * ratio:
        raise RecordingError(
            f"a chunk of {packed} bytes claims to inflate to {claimed}, more than "
            f"{compression or 'an uncompressed chunk'} can: a corrupt or hostile file")
    return claimed


def inflate(compression: str, data: bytes, claimed: int) -> bytes:
    """The chunk's bytes, uncompressed; the inflation stops at the size it claims, and at its
    first block if that does not begin with a record."""
    if compression == "zstd":
        stream = zstandard.ZstdDecompressor().stream_reader(data, read_across_frames=True)
        first = stream.read(min(_READ, claimed + 1))
        _check_first(first, claimed)
        out = _read_bounded(stream, first, claimed)
    elif compression == "lz4":
        out = lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=claimed + 1)
    else:
        out = data
    if len(out) != claimed:
        raise RecordingError(f"a chunk inflates to {'more' if len(out) > claimed else 'less'} "
                             f"than the {claimed} bytes it claims: a corrupt or hostile file")
    _check_first(out, claimed)
    return out


def _check_first(first: bytes, claimed: int) -> None:
    if len(first) > claimed or len(first) < _HEAD.size:
        return  # the size check says what is wrong
    opcode, length = _HEAD.unpack_from(first)
    if opcode == 0 or length > claimed - _HEAD.size:
        raise RecordingError("a chunk does not begin with a record (opcode 0x00 or a length "
                             "past its end): a corrupt or hostile file")


def _read_bounded(stream: BinaryIO, first: bytes, claimed: int) -> bytes:
    parts = [first]
    got = len(first)
    while got <= claimed:
        part = stream.read(min(_READ, claimed + 1 - got))
        if not part:
            break
        parts.append(part)
        got += len(part)
    return b"".join(parts)


def chunk_records(data: bytes) -> Iterator[tuple[int, int, int]]:
    """(opcode, body offset, body length) of every record in a chunk's bytes."""
    offset, end = 0, len(data)
    while offset < end:
        if end - offset < _HEAD.size:
            raise RecordingError("a chunk ends inside a record header: a corrupt file")
        opcode, length = _HEAD.unpack_from(data, offset)
        offset += _HEAD.size
        if opcode == 0 or length > end - offset:
            raise RecordingError("a chunk holds a record of opcode 0x00 or one longer than "
                                 "the chunk: a corrupt or hostile file")
        yield opcode, offset, length
        offset += length


def chunk_messages(data: bytes) -> Iterator[tuple[int, int, bytes]]:
    """(channel id, log time, CDR) of every message in a chunk's bytes, in file order."""
    for opcode, offset, length in chunk_records(data):
        if opcode == MESSAGE and length >= _MESSAGE.size:
            channel, _seq, log_time, _pub = _MESSAGE.unpack_from(data, offset)
            yield channel, log_time, data[offset + _MESSAGE.size: offset + length]


def read_exact(file: BinaryIO, offset: int, size: int) -> bytes:
    """``size`` bytes at ``offset``, or a clear error if the file is shorter."""
    file.seek(offset)
    data = file.read(size)
    if len(data) != size:
        raise RecordingError(f"the file ends {size - len(data)} bytes short of a chunk: "
                             "cut or truncated since it was opened")
    return data

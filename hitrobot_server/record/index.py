"""Where a recording's messages are: its chunks, their times and channels, without inflating
them. A whole file is indexed by its MCAP summary (chunk indexes and statistics: opening it
reads the footer and the summary, whatever the file's length). A file without one (cut by a
power loss, or written without) is scanned once, record headers only, chunk bytes skipped; its
chunks' message indexes say which channels each holds. Only a chunk that no index describes (or
that brings a channel's definition) is inflated to learn it, and what those add up to is
checked against ``--max-inflated`` before the first is inflated.
"""

from __future__ import annotations

import io
import logging
import struct
from dataclasses import dataclass, field
from typing import BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.reader import SeekingReader
from mcap.records import Channel, MessageIndex, Schema

from .inflate import (
    CHANNEL,
    MESSAGE,
    SCHEMA,
    Budget,
    believable,
    chunk_records,
    inflate,
    read_exact,
)
from .schemas import RecordingError

log = logging.getLogger(__name__)

_HEAD = struct.Struct("<BQ")
_CHUNK = struct.Struct("<QQQII")  # start, end, uncompressed size, crc, compression length
_MESSAGE = struct.Struct("<HIQQ")
FOOTER, CHUNK, MESSAGE_INDEX = 0x02, 0x06, 0x07
REGION = 1 << 20
"""Messages written outside chunks are read in runs of about this many bytes."""
_RECORDS = {SCHEMA: Schema, CHANNEL: Channel}


@dataclass(slots=True)
class ChunkRef:
    """One chunk (or a run of messages outside chunks): where its bytes are and what it holds."""

    offset: int  # where its (compressed) bytes begin in the file
    packed: int
    compression: str
    claimed: int  # the size it inflates to
    start: int  # log times of its first and last message (ns)
    end: int
    channels: set[int] | None = None  # None: no index says


@dataclass
class FileIndex:
    chunks: list[ChunkRef] = field(default_factory=list)
    schemas: list[Schema] = field(default_factory=list)
    channels: list[Channel] = field(default_factory=list)
    counts: dict[int, int] = field(default_factory=dict)  # messages per channel
    complete: bool = False  # False: cut short before the footer
    end: int = 0  # bytes of the file indexed


def from_summary(file: BinaryIO, limit: int) -> FileIndex | None:
    """The index the file's summary gives, or None if it has none that says where every
    message is (chunk indexes with their message indexes, and statistics)."""
    try:
        file.seek(0)
        summary = SeekingReader(file, record_size_limit=limit).get_summary()
    except Exception:  # no footer, or a broken one: a cut file
        return None
    stats = summary.statistics if summary else None
    if summary is None or stats is None or not summary.chunk_indexes or any(
            not ci.message_index_offsets for ci in summary.chunk_indexes):
        return None
    index = FileIndex(schemas=list(summary.schemas.values()),
                      channels=list(summary.channels.values()),
                      counts=dict(stats.channel_message_counts), complete=True)
    for ci in summary.chunk_indexes:
        head = 1 + 8 + _CHUNK.size + len(ci.compression.encode()) + 8
        ref = ChunkRef(ci.chunk_start_offset + head, ci.compressed_size, ci.compression,
                       ci.uncompressed_size, ci.message_start_time, ci.message_end_time,
                       set(ci.message_index_offsets))
        check_chunk(ref, limit)
        index.chunks.append(ref)
    return index


def check_chunk(ref: ChunkRef, limit: int) -> None:
    """A chunk replay may open: believable, and within ``--max-inflated`` on its own."""
    believable(ref.compression, ref.packed, ref.claimed)
    Budget(limit).take(ref.claimed, f"a chunk of {ref.packed} bytes")


class _Scan:
    """One pass over a file's records, reading headers and skipping chunks' bytes."""

    def __init__(self, file: BinaryIO, size: int, limit: int):
        self.file, self.size, self.limit = file, size, limit
        self.index = FileIndex()
        self.region: ChunkRef | None = None
        self.indexed: ChunkRef | None = None  # the chunk message indexes now describe

    def run(self) -> FileIndex:
        pos = 8
        while pos + _HEAD.size <= self.size:
            opcode, length = _HEAD.unpack(read_exact(self.file, pos, _HEAD.size))
            body = pos + _HEAD.size
            if length > self.size - body:
                break  # cut inside this record
            if opcode == FOOTER:
                self.index.complete = True
                break
            self.record(opcode, body, length)
            pos = body + length
        self.region = None
        self.index.end = pos
        return self.index

    def record(self, opcode: int, body: int, length: int) -> None:
        if opcode != MESSAGE:
            self.region = None
        if opcode != MESSAGE_INDEX and opcode != CHUNK:
            self.indexed = None
        if opcode == MESSAGE and length >= _MESSAGE.size:
            self.message(body, length)
        elif opcode == CHUNK:
            self.chunk(body, length)
        elif opcode == MESSAGE_INDEX and self.indexed is not None:
            entry = MessageIndex.read(ReadDataStream(io.BytesIO(self.body(body, length))))
            if entry.records:
                self.indexed.channels = (self.indexed.channels or set()) | {entry.channel_id}
                counts = self.index.counts
                counts[entry.channel_id] = counts.get(entry.channel_id, 0) + len(entry.records)
        elif opcode in _RECORDS:
            add_record(self.index, opcode, self.body(body, length))

    def body(self, body: int, length: int) -> bytes:
        if length > self.limit:
            raise RecordingError(f"a record of {length} bytes at {body}: over --max-inflated")
        return read_exact(self.file, body, length)

    def chunk(self, body: int, length: int) -> None:
        start, end, claimed, _crc, size = _CHUNK.unpack(read_exact(self.file, body, _CHUNK.size))
        compression = read_exact(self.file, body + _CHUNK.size, min(size, 16)).decode(
            errors="replace")
        data = body + _CHUNK.size + size + 8
        ref = ChunkRef(data, body + length - data, compression, claimed, start, end)
        check_chunk(ref, self.limit)
        self.index.chunks.append(ref)
        self.indexed = ref

    def message(self, body: int, length: int) -> None:
        channel, _seq, log_time, _pub = _MESSAGE.unpack(read_exact(self.file, body,
                                                                    _MESSAGE.size))
        self.index.counts[channel] = self.index.counts.get(channel, 0) + 1
        region = self.region
        if region is None or region.claimed >= REGION:
            region = self.region = ChunkRef(body - _HEAD.size, 0, "", 0, log_time, log_time,
                                            set())
            self.index.chunks.append(region)
        region.packed = region.claimed = body + length - region.offset
        region.start, region.end = min(region.start, log_time), max(region.end, log_time)
        region.channels.add(channel)  # type: ignore[union-attr]


def add_record(index: FileIndex, opcode: int, body: bytes) -> None:
    record = _RECORDS[opcode].read(ReadDataStream(io.BytesIO(body)))
    (index.schemas if opcode == SCHEMA else index.channels).append(record)


def scan(file: BinaryIO, size: int, limit: int) -> FileIndex:
    """Index a file without a summary, in one pass; then open, within the budget, the chunks
    no index describes or that bring a channel's definition."""
    index = _Scan(file, size, limit).run()
    known = {c.id for c in index.channels}
    opened: list[ChunkRef] = []
    for ref in index.chunks:
        if ref.channels is None or not ref.channels <= known:
            opened.append(ref)
            known |= ref.channels or set()
    total = sum(ref.claimed for ref in opened)
    if total > limit:
        Budget(limit).take(total, "the file's chunks")  # (those no index describes)
    for ref in opened:
        learn(index, ref, inflate(ref.compression, read_exact(file, ref.offset, ref.packed),
                                  ref.claimed))
    return index


def learn(index: FileIndex, ref: ChunkRef, data: bytes) -> None:
    """What an opened chunk holds: its definitions, and (if no index said) its channels."""
    channels: set[int] = set()
    for opcode, offset, length in chunk_records(data):
        if opcode in _RECORDS:
            add_record(index, opcode, data[offset: offset + length])
        elif opcode == MESSAGE and length >= _MESSAGE.size and ref.channels is None:
            channel = _MESSAGE.unpack_from(data, offset)[0]
            channels.add(channel)
            index.counts[channel] = index.counts.get(channel, 0) + 1
    if ref.channels is None:
        ref.channels = channels

"""Reading a recording for replay, whatever state the file is in.

The file is read as a stream (MCAP's non-seeking mode), so a recording cut by a power loss (no
footer, no summary, a last chunk half written) plays up to its last whole record. What it
inflates is bounded before anything is inflated: a chunk's ``uncompressed_size`` must be one its
compressed bytes can produce (a zstd block of 128 KiB costs at least 3 bytes, an LZ4 match byte
at most 255) and must fit what is left of the budget (``--max-inflated``); the inflation itself
stops at the size the chunk claims. A bomb is refused in the time it takes to read its headers.
"""

from __future__ import annotations

import logging
import os
import struct
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import BinaryIO

import lz4.frame
import zstandard
from mcap.exceptions import McapError
from mcap.records import Channel, Chunk, Footer, McapRecord, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk

from ..types.registry import MsgType, TypeRegistry
from .profile import AUDIT_TOPIC, is_latched
from .schemas import RecordingError, Schemas

log = logging.getLogger(__name__)

MAGIC = b"\x89MCAP0\r\n"
DEFAULT_MAX_INFLATED = 1024 * 2**20
"""Bytes a replay may hold of a recording by default (``--max-inflated``)."""
MAX_RATIO = {"zstd": 131072 // 3 + 1, "lz4": 256, "": 1}
"""The most a byte of each compression can inflate to (an upper bound, never reached)."""
_READ = 1 << 20
# the audit trail, and the state of a recorder or player at the time: the replaying server
# has its own
NOT_REPLAYED = frozenset({AUDIT_TOPIC, "/replay/state", "/record/state"})


@dataclass(frozen=True, slots=True)
class Track:
    topic: str
    mtype: MsgType
    latched: bool


@dataclass
class Recording:
    """A readable recording: its tracks and messages (log time order), raw CDR."""

    path: Path
    tracks: dict[int, Track]
    times: list[float]  # seconds from the first message
    messages: list[tuple[int, int, bytes]]  # (channel id, log time ns, CDR)
    complete: bool = True  # False: cut short, served as far as it goes

    @property
    def duration(self) -> float:
        return self.times[-1] if self.times else 0.0

    @property
    def start_ns(self) -> int:
        """Log time of the first message (the replay clock's origin)."""
        return self.messages[0][1] if self.messages else 0


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


def believable(chunk: Chunk) -> int:
    """The size a chunk claims to inflate to, if its compressed bytes can produce it."""
    claimed, packed = chunk.uncompressed_size, len(chunk.data)
    ratio = MAX_RATIO.get(chunk.compression)
    if ratio is None:
        raise RecordingError(f"a chunk is compressed with {chunk.compression!r}, which replay "
                             "does not read (zstd, lz4 or none)")
    if claimed > max(packed, 1) * ratio:
        raise RecordingError(
            f"a chunk of {packed} bytes claims to inflate to {claimed}, more than "
            f"{chunk.compression or 'an uncompressed chunk'} can: a corrupt or hostile file")
    return claimed


def inflate(chunk: Chunk, budget: Budget) -> Chunk:
    """The chunk, uncompressed, after checking its claimed size; the inflation stops there."""
    claimed = believable(chunk)
    budget.take(claimed, f"a chunk of {len(chunk.data)} bytes")
    if chunk.compression == "zstd":
        data = _read_bounded(zstandard.ZstdDecompressor().stream_reader(
            chunk.data, read_across_frames=True), claimed)
    elif chunk.compression == "lz4":
        data = lz4.frame.LZ4FrameDecompressor().decompress(chunk.data, max_length=claimed + 1)
    else:
        data = chunk.data
    if len(data) != claimed:
        raise RecordingError(f"a chunk inflates to {'more' if len(data) > claimed else 'less'} "
                             f"than the {claimed} bytes it claims: a corrupt or hostile file")
    return replace(chunk, compression="", data=data)


def _read_bounded(stream: BinaryIO, claimed: int) -> bytes:
    parts: list[bytes] = []
    got = 0
    while got <= claimed:
        part = stream.read(min(_READ, claimed + 1 - got))
        if not part:
            break
        parts.append(part)
        got += len(part)
    return b"".join(parts)


def _stream(file: BinaryIO, limit: int) -> Iterator[McapRecord]:
    file.seek(0)
    return StreamReader(file, skip_magic=False, emit_chunks=True, record_size_limit=min(
        limit, os.fstat(file.fileno()).st_size)).records


def check_claims(file: BinaryIO, budget: Budget) -> None:
    """Refuse a file whose chunks claim more than the budget in all, before inflating any (a
    first pass over the compressed bytes; a cut file is checked as far as it goes)."""
    total = 0
    try:
        for record in _stream(file, budget.limit):
            if isinstance(record, Chunk):
                total += believable(record)
                if total > budget.limit:
                    budget.take(total, "the file's chunks")
    except RecordingError:
        raise
    except (McapError, ValueError, EOFError, struct.error):
        return  # a cut or broken record: the reading pass says how far the file goes


def records(file: BinaryIO, budget: Budget) -> Iterator[McapRecord]:
    """Every record of the file in order, chunks opened within the budget."""
    for record in _stream(file, budget.limit):
        if isinstance(record, Chunk):
            yield from breakup_chunk(inflate(record, budget))
        else:
            if isinstance(record, Message):
                budget.take(len(record.data), "a message")
            yield record


class _Collect:
    """The tracks and messages of a file, as its records come."""

    def __init__(self, schemas: Schemas):
        self.schemas = schemas
        self.channels: dict[int, Channel] = {}
        self.skipped: set[int] = set()
        self.messages: list[tuple[int, int, bytes]] = []
        self.complete = False

    def add(self, record: McapRecord) -> None:
        if isinstance(record, Schema):
            self.schemas.add(record)
        elif isinstance(record, Channel):
            if record.id in self.channels or record.id in self.skipped:
                return
            if record.topic in NOT_REPLAYED:
                self.skipped.add(record.id)
                return
            self.schemas.check(record)
            self.channels[record.id] = record
        elif isinstance(record, Message) and record.channel_id in self.channels:
            self.messages.append((record.channel_id, record.log_time, record.data))
        elif isinstance(record, Footer):
            self.complete = True


def _mcap_of(path: Path) -> Path:
    """A rosbag2 bag folder (``metadata.yaml`` beside the ``.mcap``) stands for its one file."""
    if not path.is_dir():
        return path
    files = sorted(path.glob("*.mcap"))
    if len(files) != 1:
        raise RecordingError(f"{path} is a folder with {len(files)} .mcap files: name the one "
                             "to replay")
    return files[0]


def load_recording(path: Path | str, types: TypeRegistry,
                   max_inflated: int = DEFAULT_MAX_INFLATED) -> Recording:
    """Read a recording (blocking; run it in a thread). Types the file defines differently from
    ``types`` (or that ``types`` lacks) are taken into ``types`` from the file's own schemas, so
    give it the replaying server's registry."""
    path = _mcap_of(Path(path))
    try:
        file = open(path, "rb")  # noqa: SIM115 - closed below
    except OSError as exc:
        raise RecordingError(f"cannot open {path}: {exc.strerror or exc}") from None
    with file:
        if file.read(len(MAGIC)) != MAGIC:
            raise RecordingError(f"{path} is not an MCAP file")
        budget = Budget(max_inflated)
        check_claims(file, budget)
        collect = _Collect(Schemas(types))
        try:
            for record in records(file, budget):
                collect.add(record)
        except RecordingError:
            raise
        except Exception as exc:  # a cut or broken record: what came before it plays
            log.warning("%s: broken after %d bytes (%s: %s); replaying the %d messages before",
                        path.name, file.tell(), type(exc).__name__, exc or "bad record",
                        len(collect.messages))
    if not collect.complete:
        log.warning("%s ends before the MCAP footer (a recording that was cut off): replaying "
                    "the %d messages it holds", path.name, len(collect.messages))
    if not collect.messages:
        raise RecordingError(f"{path} has no ROS 2 messages to replay"
                             + ("" if collect.complete else " (it is cut off before any)"))
    mtypes = collect.schemas.adopt()
    tracks = {cid: Track(ch.topic, mtypes[cid], is_latched(dict(ch.metadata)))
              for cid, ch in collect.channels.items()}
    messages = sorted(collect.messages, key=lambda m: m[1])
    first = messages[0][1]
    return Recording(path, tracks, [(m[1] - first) / 1e9 for m in messages], messages,
                     collect.complete)

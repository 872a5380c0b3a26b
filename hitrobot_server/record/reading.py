"""Reading a recording for replay, whatever state the file is in, a chunk at a time.

Opening a file reads its index (:mod:`.index`: the MCAP summary, or one scan of a file cut
before it has one); playing reads the chunks in log-time order as the clock reaches them and
lets each go once played, and a seek jumps to the chunks that hold the time. What a replay holds
is bounded: the chunks that overlap one instant (one or two of ~1 MiB as our recorder writes
them; each, and their sum, at most ``--max-inflated``), plus one message per latched topic while
a seek fetches them. Every chunk's inflation is bounded before it starts (:mod:`.inflate`), so a
bomb is refused in the time it takes to read its headers.
"""

from __future__ import annotations

import bisect
import heapq
import logging
import os
import weakref
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from mcap.records import Channel

from ..types.registry import MsgType, TypeRegistry
from .index import ChunkRef, FileIndex, from_summary, scan
from .inflate import Budget, chunk_messages, inflate, read_exact
from .profile import AUDIT_TOPIC, is_latched
from .schemas import RecordingError, Schemas

log = logging.getLogger(__name__)

MAGIC = b"\x89MCAP0\r\n"
DEFAULT_MAX_INFLATED = 1024 * 2**20
"""Bytes a replay may hold inflated at once, and inflate to index a file (``--max-inflated``)."""
# the audit trail, and the state of a recorder or player at the time: the replaying server
# has its own
NOT_REPLAYED = frozenset({AUDIT_TOPIC, "/replay/state", "/record/state"})

Entry = tuple[int, int, bytes]  # (channel id, log time ns, CDR)


@dataclass(frozen=True, slots=True)
class Track:
    topic: str
    mtype: MsgType
    latched: bool


class Messages:
    """A recording's messages, read when iterated (log time order); ``len`` from the index."""

    def __init__(self, recording: Recording):
        self.recording = recording

    def __len__(self) -> int:
        return self.recording.count

    def __iter__(self) -> Iterator[Entry]:
        return self.recording.cursor(0.0)


class Recording:
    """A readable recording: its tracks and an index of its chunks; messages raw CDR, read from
    the file a chunk at a time (:meth:`cursor`, :meth:`latched_before`)."""

    def __init__(self, path: Path, file: BinaryIO, tracks: dict[int, Track], index: FileIndex,
                 count: int):
        self.path = path
        self.file = file
        weakref.finalize(self, file.close)
        self.tracks = tracks
        self.complete = index.complete  # False: cut short, served as far as it goes
        self.count = count
        self.chunks = sorted(index.chunks, key=lambda c: (c.start, c.offset))
        self._reach: list[int] = []  # the latest end among the chunks up to each
        for chunk in self.chunks:
            self._reach.append(max(chunk.end, self._reach[-1] if self._reach else chunk.end))
        self._kept = set(tracks)
        self._latched = {cid for cid, track in tracks.items() if track.latched}
        self._strict = True  # while opening, a chunk that cannot be read refuses the file
        self.start_ns = 0  # log time of the first message (the replay clock's origin)
        first = next(self.cursor(0.0), None)
        if first is None:
            raise RecordingError(f"{path} has no readable messages to replay")
        self.start_ns = first[1]
        self.end_ns = self._last()
        self._strict = False

    @property
    def messages(self) -> Messages:
        return Messages(self)

    @property
    def duration(self) -> float:
        return self.seconds(self.end_ns)

    def seconds(self, log_time: int) -> float:
        """A log time as seconds from the first message."""
        return (log_time - self.start_ns) / 1e9

    def close(self) -> None:
        self.file.close()

    def _read(self, chunk: ChunkRef) -> list[Entry]:
        """A chunk's messages on replayed channels (file order); a chunk that cannot be read
        while playing is skipped with a warning (what plays around it still plays)."""
        try:
            data = inflate(chunk.compression, read_exact(self.file, chunk.offset, chunk.packed),
                           chunk.claimed)
            return [m for m in chunk_messages(data) if m[0] in self._kept]
        except (RecordingError, OSError, ValueError) as exc:
            if self._strict:
                raise
            log.warning("replay: the chunk at byte %d of %s is skipped: %s", chunk.offset,
                        self.path.name, exc)
            return []

    def _holds(self, chunk: ChunkRef, channels: set[int]) -> bool:
        return chunk.channels is None or not chunk.channels.isdisjoint(channels)

    def cursor(self, position: float) -> Iterator[Entry]:
        """The messages at ``position`` (seconds) and after, in log time order (file order
        among equal times); chunks are read as the order reaches them, overlapping ones
        merged."""
        floor = self.start_ns + int(position * 1e9) - 1
        i = bisect.bisect_left(self._reach, floor)  # every chunk before ends before it
        chunks, heap = self.chunks, []
        while True:
            while i < len(chunks) and (not heap or chunks[i].start <= heap[0][0]):
                chunk = chunks[i]
                i += 1
                if chunk.end < floor or not self._holds(chunk, self._kept):
                    continue
                for seq, (channel, log_time, data) in enumerate(self._read(chunk)):
                    if self.seconds(log_time) >= position:
                        heapq.heappush(heap, (log_time, chunk.offset, seq, channel, data))
            if not heap:
                return
            log_time, _offset, _seq, channel, data = heapq.heappop(heap)
            yield channel, log_time, data

    def latched_before(self, position: float) -> list[Entry]:
        """Each latched topic's latest message before ``position``, in log time order: read
        from the chunks that hold one, latest first, until no earlier chunk can hold a later
        one."""
        ceiling = self.start_ns + int(position * 1e9) + 1
        found: dict[int, tuple[tuple[int, int, int], Entry]] = {}
        candidates = [c for c in self.chunks
                      if c.start < ceiling and self._holds(c, self._latched)]
        candidates.sort(key=lambda c: min(c.end, ceiling), reverse=True)
        for chunk in candidates:
            bound = min(chunk.end, ceiling)
            wanted = self._latched if chunk.channels is None else (
                chunk.channels & self._latched)
            if all(c in found and found[c][0][0] > bound for c in wanted):
                continue
            for seq, entry in enumerate(self._read(chunk)):
                channel, log_time, _data = entry
                key = (log_time, chunk.offset, seq)
                if channel in self._latched and self.seconds(log_time) < position and (
                        channel not in found or key > found[channel][0]):
                    found[channel] = (key, entry)
        return [entry for _key, entry in sorted(found.values(), key=lambda f: f[0])]

    def _last(self) -> int:
        """The log time of the last message: the chunks that end latest, read until no other
        can hold a later one."""
        last = self.start_ns
        for chunk in sorted(self.chunks, key=lambda c: c.end, reverse=True):
            if chunk.end <= last:
                break
            if self._holds(chunk, self._kept):
                last = max([last, *(m[1] for m in self._read(chunk))])
        return last


def _tracks(index: FileIndex, schemas: Schemas) -> dict[int, Track]:
    """The channels replay serves (ROS 2, with schemas that parse), each with its type."""
    for schema in index.schemas:
        schemas.add(schema)
    channels: dict[int, Channel] = {}
    for channel in index.channels:
        if channel.id not in channels and channel.topic not in NOT_REPLAYED:
            schemas.check(channel)
            channels[channel.id] = channel
    mtypes = schemas.adopt()
    return {cid: Track(ch.topic, mtypes[cid], is_latched(dict(ch.metadata)))
            for cid, ch in channels.items()}


def check_overlap(chunks: list[ChunkRef], limit: int) -> None:
    """Refuse a file whose chunks overlapping one instant (read together to merge them in log
    time order) would inflate to more than ``--max-inflated`` at once."""
    events = sorted([(c.start, 0, c.claimed) for c in chunks]
                    + [(c.end, 1, -c.claimed) for c in chunks])
    held = most = 0
    for _time, _kind, size in events:
        held += size
        most = max(most, held)
    if most > limit:
        Budget(limit).take(most, "the chunks that overlap in time")


def _mcap_of(path: Path) -> Path:
    """A rosbag2 bag folder (``metadata.yaml`` beside the ``.mcap``) stands for its one file."""
    if not path.is_dir():
        return path
    files = sorted(path.glob("*.mcap"))
    if len(files) != 1:
        raise RecordingError(f"{path} is a folder with {len(files)} .mcap files: name the one "
                             "to replay")
    return files[0]


def _index(path: Path, file: BinaryIO, limit: int) -> FileIndex:
    if file.read(len(MAGIC)) != MAGIC:
        raise RecordingError(f"{path} is not an MCAP file")
    index = from_summary(file, limit)
    if index is None:
        size = os.fstat(file.fileno()).st_size
        index = scan(file, size, limit)
        if not index.complete and index.end + 16 < size:
            log.warning("%s: a broken record after %d bytes; replaying what comes before",
                        path.name, index.end)
    check_overlap(index.chunks, limit)
    return index


def load_recording(path: Path | str, types: TypeRegistry,
                   max_inflated: int = DEFAULT_MAX_INFLATED) -> Recording:
    """Open a recording (blocking; run it in a thread): its index, not its messages. Types the
    file defines differently from ``types`` (or that ``types`` lacks) are taken into ``types``
    from the file's own schemas, so give it the replaying server's registry."""
    path = _mcap_of(Path(path))
    try:
        file = open(path, "rb")  # noqa: SIM115 - the recording closes it
    except OSError as exc:
        raise RecordingError(f"cannot open {path}: {exc.strerror or exc}") from None
    try:
        index = _index(path, file, max_inflated)
        tracks = _tracks(index, Schemas(types))
        count = sum(index.counts.get(cid, 0) for cid in tracks)
        if not count:
            raise RecordingError(f"{path} has no ROS 2 messages to replay"
                                 + ("" if index.complete else " (it is cut off before any)"))
        if not index.complete:
            log.warning("%s ends before the MCAP footer (a recording that was cut off): "
                        "replaying the %d messages it holds", path.name, count)
        return Recording(path, file, tracks, index, count)
    except BaseException:
        file.close()
        raise

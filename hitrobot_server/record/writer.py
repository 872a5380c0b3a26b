"""The recorder's writer process: CDR encoding and MCAP writing, away from the server's GIL.

A thread would share the GIL with the event loop: encoding a LaserScan is pure Python, and a
thread busy with it makes every socket call of the loop wait for the GIL again (the convoy
effect: measured 4× slower fan-out and 1.4 s probe stalls during 4000² maps). So the server only
hands over batches of messages, each as bytes where it has them (the CDR it or someone else
already made, or the client's own JSON of a publish), down a pipe the server's loop writes
(:mod:`.handoff`, recorder.PipeFeed), and this process, started with spawn at a lower
priority, encodes what is not CDR yet and writes. It closes the current chunk every
``flush_period`` seconds and finishes the file when told to stop or when the server dies. A disk
that refuses a write (full, a size limit) ends the recording with a file that reads back to its
last complete chunk.

:func:`write_recording` writes already-made messages into a new file in one go (the black
box's snapshots).
"""

from __future__ import annotations

import contextlib
import datetime
import errno
import logging
import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from mcap.data_stream import RecordBuilder
from mcap.records import DataEnd, Footer
from mcap.writer import MCAP0_MAGIC, CompressionType, Writer

from .. import __version__
from ..bus.cdr import codec_for
from ..types import jsoncodec
from ..types.registry import TypeRegistry
from .files import DiskFile, enforce_budget, open_file, split_name
from .handoff import CDR, JSON, Item, read_batch
from .profile import PROFILE, ROS_DISTRO, channel_metadata, ros2_type_name, schema_text

log = logging.getLogger(__name__)

WRITER_NICENESS = 5  # the event loop first; the disk keeps up or messages are dropped
DRAIN_GRACE = 5.0  # seconds a writer whose server died has to write what the pipe still holds
BUDGET_PERIOD = 2.0  # seconds between looks at the disk budget

@dataclass
class Counters:
    """Shared with the server. Each is written by one side only, so no lock is shared (a
    server killed while holding one would leave the writer waiting forever)."""

    queued: Any  # server: sizes of the items it queued (multiprocessing.Value('q'))
    taken: Any  # writer: sizes of the items it took; queued - taken is in the queue
    messages: Any
    failed: Any
    parts: Any  # files started
    bytes: Any  # bytes in the files at the last flush
    error: Any  # writer: the errno of the disk error that ended the recording (0: none)

    @classmethod
    def create(cls, ctx) -> Counters:
        return cls(*(ctx.Value("q", 0, lock=False) for _ in range(7)))


MAX_CHUNKS = 7200
"""Chunks in one file before the recording goes on in a new part (NAME_1.mcap, ...): the MCAP
writer keeps every chunk's index in memory until the file's summary is written, so an open file
grows the writer process (about 30 MB an hour of 0.5 s chunks on 50 channels). 7,200 chunks is
an hour at the flush period; a recording of a day is 24 parts, the writer's memory flat."""


@dataclass(frozen=True)
class Plan:
    """What the writer writes: where, when it starts a new file, what budget it keeps."""

    path: Path
    exclusive: bool = True  # a file that exists is refused (a client's name), else emptied
    split_size: int = 0  # bytes (0: never)
    split_time: float = 0.0  # seconds of log time per file (0: never)
    flush_period: float = 0.5
    max_disk: int = 0  # bytes of recordings kept (0: no budget)
    budget_folder: Path | None = None  # the recordings folder the budget also prunes
    max_chunks: int = 0  # chunks per file (0: MAX_CHUNKS); see MAX_CHUNKS


class McapFiles:
    """The MCAP files of one recording, written in order (split by size or by time)."""

    def __init__(self, plan: Plan, counters: Counters, *, created: bool = True):
        self.plan = plan
        self.chunk_span = int(plan.flush_period * 1e9)  # a chunk covers at most this log time
        self.chunk_start: int | None = None  # log time of the current chunk's first message
        self.file_start: int | None = None  # log time of the current file's first message
        self.counters = counters
        self.codec = codec_for(TypeRegistry.default())
        self.latched: dict[str, Item] = {}  # each topic's latest, to open the next file with
        self.index = -1
        self.file: DiskFile | None = None
        self.closed_bytes = 0
        self.next_budget = 0.0
        self._open(created)

    @property
    def current(self) -> Path:
        return split_name(self.plan.path, self.index)

    def _open(self, created: bool = False) -> None:
        self.index += 1
        self.file = DiskFile(open_file(self.current, create=not created,
                                       exclusive=self.plan.exclusive))
        self.file_start = self.chunk_start = None
        self.chunks = 0  # closed in this file
        self.writer = Writer(self.file, compression=CompressionType.ZSTD)
        self.writer.start(profile=PROFILE, library=f"hitrobot-server {__version__}")
        self.writer.add_metadata("hitrobot-server", {
            "version": __version__,
            "ROS_DISTRO": ROS_DISTRO,
            "started": datetime.datetime.now(datetime.UTC).isoformat(),
            "part": str(self.index),
        })
        self.channels: dict[str, int] = {}
        self.schemas: dict[str, int] = {}
        self.counters.parts.value = self.index + 1
        self.keep_budget()

    def flush(self) -> None:
        """Close the chunk in progress and hand it to the OS; roll over when the file is full;
        keep the disk budget."""
        self.writer.flush()
        if self.chunk_start is not None:
            self.chunks += 1
        self.chunk_start = None
        size = self.file.tell()
        self.counters.bytes.value = self.closed_bytes + size
        if (self.plan.split_size and size >= self.plan.split_size) or (
                self.chunks >= (self.plan.max_chunks or MAX_CHUNKS)):
            self.roll()
        elif time.monotonic() >= self.next_budget:
            self.keep_budget()

    def roll(self) -> None:
        self.finish()
        self._open()
        self.write_all(self.latched.values())

    def keep_budget(self) -> None:
        plan = self.plan
        self.next_budget = time.monotonic() + BUDGET_PERIOD
        if not plan.max_disk:
            return
        own = [split_name(plan.path, i) for i in range(self.index)]
        folders = {plan.budget_folder} if plan.budget_folder is not None else set()
        enforce_budget(folders, own, plan.max_disk, {self.current})

    def finish(self) -> None:
        if self.file is None:
            return
        try:
            self.writer.finish()
        finally:
            self._closed()

    def _closed(self) -> None:
        self.closed_bytes += self.file.tell()
        self.counters.bytes.value = self.closed_bytes
        self.file.close()
        self.file = None

    def cut_short(self, exc: OSError) -> None:
        """The disk refused a write: the file already ends with its last complete records (see
        :class:`DiskFile`); end it there with a footer without summary, which readers take
        as "read the records in order". When even that is refused, the last whole writes
        (chunks) are given up one by one until the footer fits."""
        if self.file is None:
            return
        self.counters.error.value = exc.errno or errno.EIO
        if self.file.tell() < len(MCAP0_MAGIC) + 1:  # not even its header: no file at all
            self._closed()
            with contextlib.suppress(OSError):
                self.current.unlink()
            log.error("recording to %s stopped: %s", self.current, exc.strerror or exc)
            return
        builder = RecordBuilder()
        DataEnd(0).write(builder)
        Footer(summary_start=0, summary_offset_start=0, summary_crc=0).write(builder)
        tail = builder.end() + MCAP0_MAGIC
        ends = list(self.file.ends)[1:]  # never before the header (the first two writes)
        for end in reversed(ends):  # the end of the last whole write, else an earlier one
            self.file.cut(end)
            try:
                self.file.write(tail)
                break
            except OSError:
                continue
        log.error("recording to %s stopped: %s; the file keeps what was written before",
                  self.current, exc.strerror or exc)
        self._closed()

    def write_all(self, items: Iterable[Item]) -> None:
        for item in list(items):
            self._add(item)

    def write(self, item: Item) -> None:
        """Write a message of the stream: a new file when this one spans ``split_time``, a
        new chunk when the chunk spans the flush period (a backlog still makes short ones)."""
        t, split_ns = item.log_time, int(self.plan.split_time * 1e9)
        if self.file_start is None:
            self.file_start = t
        elif split_ns and t - self.file_start >= split_ns:
            self.roll()
            self.file_start = t
        if self.chunk_start is None:
            self.chunk_start = t
        elif abs(t - self.chunk_start) >= self.chunk_span:
            self.flush()
            self.chunk_start = t
        self._add(item)

    def _add(self, item: Item) -> None:
        try:
            channel = self._channel(item)
            data = self._cdr(item)
        except Exception as exc:
            self.counters.failed.value += 1
            log.warning("recording: %s cannot be encoded (%s); message skipped", item.topic, exc)
            return
        self.writer.add_message(channel, item.log_time, data, item.publish_time, item.seq)
        self.counters.messages.value += 1
        if item.latched:
            self.latched[item.topic] = item._replace(kind=CDR, data=data)

    def _cdr(self, item: Item) -> bytes:
        if item.kind == CDR:
            return item.data
        msg = jsoncodec.loads(item.data)["msg"] if item.kind == JSON else item.data
        return self.codec.encode(msg, self.codec.types.msg(item.type_name))

    def _channel(self, item: Item) -> int:
        channel = self.channels.get(item.topic)
        if channel is not None:
            return channel
        name = ros2_type_name(item.type_name)
        schema = self.schemas.get(name)
        if schema is None:
            schema = self.schemas[name] = self.writer.register_schema(
                name, "ros2msg", schema_text(self.codec, item.type_name))
        channel = self.channels[item.topic] = self.writer.register_channel(
            item.topic, "cdr", schema, channel_metadata(item.latched))
        return channel


def write_recording(path: Path, items: Iterable[Item], *, metadata: dict[str, str] | None = None,
                    metadata_name: str = "hitrobot-recording") -> int:
    """Write ``items`` (in log-time order) into a new MCAP file ``path`` (refused if it
    exists, never through a symlink), with ``metadata`` as its ``metadata_name`` metadata
    record; the messages written. Blocking: call it off the event loop."""
    counters = Counters(*(SimpleNamespace(value=0) for _ in range(7)))
    files = McapFiles(Plan(Path(path), flush_period=3600.0), counters, created=False)
    try:
        if metadata:
            files.writer.add_metadata(metadata_name, dict(metadata))
        files.write_all(items)
        files.finish()
    except OSError as exc:
        files.cut_short(exc)
        raise
    return counters.messages.value


class _Batches:
    """The writer's end of the pipe (recorder.PipeFeed): batches (:mod:`.handoff`), an empty
    one to stop; the end of the pipe (the server gone, all it wrote read) stops it too."""

    def __init__(self, items: Any, counters: Counters):
        self.items = items
        self.counters = counters
        self.topics: dict[int, tuple[str, str]] = {}

    def take(self, timeout: float) -> list[Item] | None:
        try:
            if not self.items.poll(timeout):
                return []
            blob = self.items.recv_bytes()
        except (EOFError, OSError):
            return None
        if not blob:
            return None
        items, size = read_batch(blob, self.topics)
        self.counters.taken.value += size
        return items


def run_writer(plan: Plan, items: Any, counters: Counters) -> None:
    """The writer process: take batches until ``None``, then finish the file. If the server
    dies first, the batches it had already handed over are written (the pipe still holds
    them) and the file finished; a watchdog thread finishes it after ``DRAIN_GRACE`` if the
    main thread is stuck reading a batch the server was cut off in the middle of. A disk
    error ends it early (exit 1)."""
    with contextlib.suppress(OSError, AttributeError):
        os.nice(WRITER_NICENESS)
    with contextlib.suppress(AttributeError, ValueError):  # a size limit: an error, not a kill
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: "
                        "%(message)s")
    files = McapFiles(plan, counters)
    lock = threading.Lock()  # held while the file is touched
    gone, drained = threading.Event(), threading.Event()

    def watch_server() -> None:
        server = multiprocessing.parent_process()
        if server is None:
            return
        server.join()
        gone.set()
        drained.wait(DRAIN_GRACE)
        with lock, contextlib.suppress(OSError):
            files.finish()
        os._exit(0)

    threading.Thread(target=watch_server, name="watch-server", daemon=True).start()
    batches = _Batches(items, counters)
    next_flush = time.monotonic() + plan.flush_period
    try:
        while (batch := batches.take(max(0.0, next_flush - time.monotonic()))) is not None:
            if not batch and gone.is_set():
                break  # the server is gone and what it handed over is written
            with lock:
                for item in batch:
                    files.write(item)
                if time.monotonic() >= next_flush:
                    files.flush()
                    next_flush = time.monotonic() + plan.flush_period
        with lock:
            files.finish()
        drained.set()
    except OSError as exc:
        with lock:
            files.cut_short(exc)
        raise SystemExit(1) from None

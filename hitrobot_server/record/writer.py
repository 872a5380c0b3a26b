"""The recorder's writer process: CDR encoding and MCAP writing, away from the server's GIL.

A thread would share the GIL with the event loop: encoding a LaserScan is pure Python, and a
thread busy with it makes every socket call of the loop wait for the GIL again (the convoy
effect: measured 4× slower fan-out and 1.4 s probe stalls during 4000² maps). So the server only
queues each message (a ``multiprocessing`` queue: its feeder thread pickles, which is C code),
and this process, started with spawn at a lower priority, encodes and writes. It closes the
current chunk every ``flush_period`` seconds and finishes the file when told to stop or when
the server dies.
"""

from __future__ import annotations

import contextlib
import datetime
import logging
import multiprocessing
import os
import queue
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.writer import CompressionType, Writer

from .. import __version__
from ..bus.cdr import Ros2Codec
from ..types.registry import TypeRegistry
from .profile import (
    AUDIT_SCHEMA,
    AUDIT_SCHEMA_NAME,
    AUDIT_TOPIC,
    PROFILE,
    ROS_DISTRO,
    channel_metadata,
    ros2_type_name,
    schema_text,
)

log = logging.getLogger(__name__)

WRITER_NICENESS = 5  # the event loop first; the disk keeps up or messages are dropped


@dataclass(slots=True)
class Item:
    """One message to write (pickled across to the writer)."""

    topic: str
    type_name: str  # "" for the audit channel (``data`` is then its JSON)
    latched: bool
    log_time: int  # ns
    publish_time: int  # ns
    seq: int
    msg: Any  # the canonical message, or None when ``data`` is given
    data: bytes | None  # CDR (or the audit JSON) when already encoded
    size: int


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

    @classmethod
    def create(cls, ctx) -> Counters:
        return cls(*(ctx.Value("q", 0, lock=False) for _ in range(6)))


def split_name(path: Path, index: int) -> Path:
    """The ``index``-th file of a split recording: ``run.mcap``, ``run_1.mcap``, ..."""
    return path if index == 0 else path.with_name(f"{path.stem}_{index}{path.suffix}")


class McapFiles:
    """The MCAP files of one recording, written in order (split at ``split_size`` bytes)."""

    def __init__(self, path: Path, split_size: int, counters: Counters, chunk_span: float):
        self.path = path
        self.split_size = split_size
        self.chunk_span = int(chunk_span * 1e9)  # a chunk covers at most this much log time
        self.chunk_start: int | None = None  # log time of the current chunk's first message
        self.counters = counters
        self.codec = Ros2Codec(TypeRegistry.default())
        self.latched: dict[str, Item] = {}  # each topic's latest, to open the next file with
        self.index = -1
        self.file = None
        self.closed_bytes = 0
        self._open()

    def _open(self) -> None:
        self.index += 1
        self.file = open(split_name(self.path, self.index), "wb")  # noqa: SIM115 - see finish
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

    def flush(self) -> None:
        """Close the chunk in progress and hand it to the OS; roll over when the file is full."""
        self.writer.flush()
        self.chunk_start = None
        size = self.file.tell()
        self.counters.bytes.value = self.closed_bytes + size
        if self.split_size and size >= self.split_size:
            self.finish()
            self._open()
            self.write_all(self.latched.values())

    def finish(self) -> None:
        if self.file is None:
            return
        try:
            self.writer.finish()
        finally:
            self.closed_bytes += self.file.tell()
            self.counters.bytes.value = self.closed_bytes
            self.file.close()
            self.file = None

    def write_all(self, items: Iterable[Item]) -> None:
        for item in list(items):
            self.write(item)

    def write(self, item: Item) -> None:
        if self.chunk_start is None:
            self.chunk_start = item.log_time
        elif abs(item.log_time - self.chunk_start) >= self.chunk_span:
            self.flush()  # a backlog (writer starting, disk slow) still makes short chunks
            self.chunk_start = item.log_time
        try:
            channel = self._channel(item)
            data = item.data if item.data is not None else self.codec.encode(
                item.msg, self.codec.types.msg(item.type_name))
        except Exception as exc:
            self.counters.failed.value += 1
            log.warning("recording: %s cannot be encoded (%s); message skipped", item.topic, exc)
            return
        self.writer.add_message(channel, item.log_time, data, item.publish_time, item.seq)
        self.counters.messages.value += 1
        if item.latched:
            item.msg, item.data = None, data
            self.latched[item.topic] = item

    def _channel(self, item: Item) -> int:
        channel = self.channels.get(item.topic)
        if channel is not None:
            return channel
        if not item.type_name:  # the audit channel
            schema = self.writer.register_schema(AUDIT_SCHEMA_NAME, "jsonschema", AUDIT_SCHEMA)
            channel = self.writer.register_channel(AUDIT_TOPIC, "json", schema)
        else:
            name = ros2_type_name(item.type_name)
            schema = self.schemas.get(name)
            if schema is None:
                schema = self.schemas[name] = self.writer.register_schema(
                    name, "ros2msg", schema_text(self.codec, item.type_name))
            channel = self.writer.register_channel(
                item.topic, "cdr", schema, channel_metadata(item.latched))
        self.channels[item.topic] = channel
        return channel


def run_writer(path: str, split_size: int, flush_period: float, items: Any,
               counters: Counters) -> None:
    """The writer process: take items until ``None``, then finish the file. If the server
    dies first, a watchdog thread finishes it (the main thread may then be stuck reading a
    message the server was cut off in the middle of)."""
    with contextlib.suppress(OSError, AttributeError):
        os.nice(WRITER_NICENESS)
    logging.basicConfig(level=logging.WARNING, format="%(asctime)s %(levelname)s %(name)s: "
                        "%(message)s")
    files = McapFiles(Path(path), split_size, counters, flush_period)
    lock = threading.Lock()  # held while the file is touched

    def watch_server() -> None:
        server = multiprocessing.parent_process()
        if server is None:
            return
        server.join()
        with lock:
            files.finish()
        os._exit(0)

    threading.Thread(target=watch_server, name="watch-server", daemon=True).start()
    next_flush = time.monotonic() + flush_period
    try:
        while True:
            try:
                item = items.get(timeout=max(0.0, next_flush - time.monotonic()))
            except queue.Empty:
                item = ...
            if item is None:
                break
            with lock:
                if item is not ...:
                    counters.taken.value += item.size
                    files.write(item)
                if time.monotonic() >= next_flush:
                    files.flush()
                    next_flush = time.monotonic() + flush_period
    finally:
        with lock:
            files.finish()

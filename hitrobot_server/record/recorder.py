"""``--record FILE.mcap``: every bus message into an MCAP file (ROS 2 profile), off the loop.

The recorder is a bus tap: on the event loop it only filters the topic and queues the message
(a reference, no copy). One worker thread serialises to CDR and writes chunked, zstd-compressed
MCAP with the ``mcap`` package. zstd and the file writes release the GIL and big arrays are
copied by numpy, so the loop keeps running while a 2000² map is written. The queue is bounded
in messages and in (estimated) bytes; when the disk cannot keep up, new messages are dropped,
counted, and a warning is logged. The current chunk is closed and flushed to the file at least
every second, so a recording killed with SIGKILL reads back to within its last second.
"""

from __future__ import annotations

import asyncio
import datetime
import json
import logging
import queue
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from mcap.writer import CompressionType, Writer

from .. import __version__
from ..bus.cdr import Ros2Codec
from ..bus.core import Bus
from ..bus.names import GlobFilter
from ..bus.tap import ClientOp
from ..bus.topics import Message
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

MAX_QUEUED_MESSAGES = 20_000
MAX_QUEUED_BYTES = 64 * 1024 * 1024
FLUSH_PERIOD = 0.5  # seconds between closed chunks (a crash loses at most about this)
WARN_PERIOD = 5.0
_STOP = object()


@dataclass(slots=True)
class _Item:
    topic: str
    type_name: str
    latched: bool
    log_time: int  # ns
    publish_time: int  # ns
    seq: int
    msg: Any  # the canonical message, or the audit entry (bytes) when type_name is ""
    cdr: bytes | None
    size: int


def estimate_size(value: Any, depth: int = 0) -> int:
    """A cheap upper-ish estimate of a message's bytes (arrays dominate; no deep walk)."""
    if isinstance(value, bytes | bytearray | memoryview):
        return len(value)
    if isinstance(value, np.ndarray):
        return value.nbytes
    if isinstance(value, dict):
        return 16 + sum(estimate_size(v, depth + 1) for v in value.values()) if depth < 4 else 64
    if isinstance(value, list | tuple):
        if not value:
            return 8
        return len(value) * (estimate_size(value[0], depth + 1) if depth < 4 else 8)
    if isinstance(value, str):
        return len(value)
    return 8


def split_name(path: Path, index: int) -> Path:
    """The ``index``-th file of a split recording: ``run.mcap``, ``run_1.mcap``, ..."""
    return path if index == 0 else path.with_name(f"{path.stem}_{index}{path.suffix}")


class Recorder:
    """Records the bus into ``path`` from :meth:`start` to :meth:`stop`."""

    def __init__(
        self,
        bus: Bus,
        path: Path | str,
        *,
        topics: str | None = None,
        split_size: int = 0,
        max_queued_bytes: int = MAX_QUEUED_BYTES,
        flush_period: float = FLUSH_PERIOD,
    ):
        self.bus = bus
        self.path = Path(path)
        self.filter = GlobFilter.parse(topics)
        self.split_size = split_size
        self.max_queued_bytes = max_queued_bytes
        self.flush_period = flush_period
        self.files: list[Path] = []
        self.messages = 0  # written
        self.dropped = 0
        self.failed = 0  # messages that could not be encoded
        self.bytes = 0  # bytes of the files so far (at the last flush)
        self._queue: queue.Queue[Any] = queue.Queue(MAX_QUEUED_MESSAGES)
        self._queued_bytes = 0
        self._lock = threading.Lock()
        self._allowed: dict[str, bool] = {}
        self._thread: threading.Thread | None = None
        self._file = None
        self._last_warning = float("-inf")
        self._started_at = 0.0

    @property
    def running(self) -> bool:
        return self._thread is not None

    # ------------------------------------------------------------------ loop side
    def start(self) -> None:
        """Open the first file (an unwritable path fails here, before anything records),
        then tap the bus, latched topics' current messages first."""
        self._file = self._open(0)
        self._started_at = self.bus.clock()
        self._thread = threading.Thread(target=self._run, name="mcap-recorder", daemon=True)
        self._thread.start()
        self.bus.taps.append(self)
        for topic in list(self.bus.topics.values()):
            if topic.latched and topic.last is not None:
                self._enqueue(topic.last, log_time=self._started_at)
        log.info("recording to %s", self.path)

    async def stop(self) -> None:
        """Untap, write what is queued, finish the file (summary and index)."""
        if self._thread is None:
            return
        if self in self.bus.taps:
            self.bus.taps.remove(self)
        thread, self._thread = self._thread, None
        await asyncio.to_thread(self._queue.put, _STOP)
        await asyncio.to_thread(thread.join)
        log.info("recording finished: %s (%d messages, %d dropped)",
                 ", ".join(map(str, self.files)), self.messages, self.dropped)

    def message(self, message: Message) -> None:
        allowed = self._allowed.get(message.topic.name)
        if allowed is None:
            allowed = self._allowed[message.topic.name] = self.filter.allows(message.topic.name)
        if allowed:
            self._enqueue(message)

    def client_op(self, op: ClientOp) -> None:
        entry = json.dumps({"op": op.op, "name": op.name, "type": op.type_name,
                            "client": op.node, "address": op.peer,
                            "auth_level": op.auth_level, "time": op.stamp}).encode()
        ns = int(op.stamp * 1e9)
        self._put(_Item(AUDIT_TOPIC, "", False, ns, ns, 0, entry, None, len(entry)))

    def _enqueue(self, message: Message, log_time: float | None = None) -> None:
        topic = message.topic
        stamp = int(message.stamp * 1e9)
        cdr = message.cache.get(("cdr",))
        size = len(cdr) if cdr is not None else estimate_size(message.msg)
        when = stamp if log_time is None else int(log_time * 1e9)
        self._put(_Item(topic.name, topic.type_name, topic.latched, when, stamp, message.seq,
                        message.msg, cdr, size))

    def _put(self, item: _Item) -> None:
        with self._lock:
            room = self._queued_bytes + item.size <= self.max_queued_bytes
            if room:
                self._queued_bytes += item.size
        if room:
            try:
                self._queue.put_nowait(item)
                return
            except queue.Full:
                with self._lock:
                    self._queued_bytes -= item.size
        self.dropped += 1
        now = time.monotonic()
        if now - self._last_warning >= WARN_PERIOD:
            self._last_warning = now
            log.warning("recording to %s cannot keep up: %d messages dropped so far",
                        self.path, self.dropped)

    # ------------------------------------------------------------------ worker thread
    def _open(self, index: int):
        path = split_name(self.path, index)
        if path.suffix != ".mcap":
            raise ValueError(f"--record: {path} must end in .mcap")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            file = open(path, "wb")  # noqa: SIM115 - closed by _finish, from the worker
        except OSError as exc:
            raise ValueError(f"cannot record to {path}: {exc.strerror or exc}") from None
        self.files.append(path)
        self._writer = Writer(file, compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library=f"hitrobot-server {__version__}")
        self._writer.add_metadata("hitrobot-server", {
            "version": __version__,
            "ROS_DISTRO": ROS_DISTRO,
            "started": datetime.datetime.now(datetime.UTC).isoformat(),
            "part": str(index),
        })
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self._index = index
        return file

    def _run(self) -> None:
        codec = Ros2Codec(self.bus.types)
        latched: dict[str, _Item] = {}
        next_flush = time.monotonic() + self.flush_period
        try:
            while True:
                try:
                    item = self._queue.get(timeout=max(0.0, next_flush - time.monotonic()))
                except queue.Empty:
                    item = None
                if item is _STOP:
                    break
                if item is not None:
                    with self._lock:
                        self._queued_bytes -= item.size
                    if self._write(codec, item) and item.latched:
                        latched[item.topic] = item
                if time.monotonic() >= next_flush:
                    self._writer.flush()
                    self.bytes = sum(f.stat().st_size for f in self.files[:-1]) + self._file.tell()
                    next_flush = time.monotonic() + self.flush_period
                    if self.split_size and self._file.tell() >= self.split_size:
                        self._roll(codec, latched.values())
        except Exception:
            log.exception("recording to %s failed; it stops here", self.path)
        finally:
            self._finish()

    def _roll(self, codec: Ros2Codec, latched: Iterable[_Item]) -> None:
        """Start the next file; it opens with the latched topics' latest messages."""
        self._finish()
        self._file = self._open(self._index + 1)
        for item in list(latched):
            self._write(codec, item)

    def _finish(self) -> None:
        if self._file is None:
            return
        try:
            self._writer.finish()
        finally:
            self._file.close()
            self.bytes = sum(f.stat().st_size for f in self.files)
            self._file = None

    def _write(self, codec: Ros2Codec, item: _Item) -> bool:
        try:
            channel = self._channel(codec, item)
            data = item.msg if not item.type_name else (
                item.cdr if item.cdr is not None
                else codec.encode(item.msg, self.bus.types.msg(item.type_name)))
        except Exception as exc:
            self.failed += 1
            log.warning("recording: %s cannot be encoded (%s); message skipped", item.topic, exc)
            return False
        self._writer.add_message(channel, item.log_time, data, item.publish_time, item.seq)
        self.messages += 1
        return True

    def _channel(self, codec: Ros2Codec, item: _Item) -> int:
        channel = self._channels.get(item.topic)
        if channel is not None:
            return channel
        if not item.type_name:  # the audit channel
            schema = self._writer.register_schema(AUDIT_SCHEMA_NAME, "jsonschema", AUDIT_SCHEMA)
            channel = self._writer.register_channel(AUDIT_TOPIC, "json", schema)
        else:
            name = ros2_type_name(item.type_name)
            schema = self._schemas.get(name)
            if schema is None:
                schema = self._schemas[name] = self._writer.register_schema(
                    name, "ros2msg", schema_text(codec, item.type_name))
            channel = self._writer.register_channel(
                item.topic, "cdr", schema, channel_metadata(item.latched))
        self._channels[item.topic] = channel
        return channel


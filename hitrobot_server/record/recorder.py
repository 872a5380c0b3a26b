"""``--record FILE.mcap``: every bus message into an MCAP file (ROS 2 profile), off the loop.

The recorder is a bus tap: on the event loop it only filters the topic and queues the message
(a reference; the queue's feeder thread pickles it) for the writer process
(:mod:`hitrobot_server.record.writer`), which encodes CDR and writes chunked, zstd-compressed
MCAP with the ``mcap`` package. The queue is bounded in messages and in (estimated) bytes; when
the disk cannot keep up, new messages are dropped, counted, and a warning is logged. The writer
closes and flushes the current chunk at least every ``flush_period`` (0.5 s), so a recording
whose server is killed with SIGKILL reads back to within its last second.
"""

from __future__ import annotations

import asyncio
import json
import logging
import multiprocessing
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..bus.core import Bus
from ..bus.names import CLIENT_NODE_PREFIX, GlobFilter
from ..bus.tap import ClientOp
from ..bus.topics import Message
from .profile import AUDIT_TOPIC
from .writer import Counters, Item, run_writer, split_name

log = logging.getLogger(__name__)

MAX_QUEUED_BYTES = 64 * 1024 * 1024
ITEM_OVERHEAD = 1024  # each queued message counts at least this (bounds the number of them)
FLUSH_PERIOD = 0.5  # seconds between closed chunks (a crash loses at most about this)
WARN_PERIOD = 5.0
READ_ONLY_SERVICES = "/rosapi/"
"""Services under this prefix only read the graph: a client calling them is not audited."""


def estimate_size(value: Any, depth: int = 0) -> int:
    """A cheap estimate of a message's bytes (arrays dominate; no deep walk)."""
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
        self.dropped = 0
        self._ctx = multiprocessing.get_context("spawn")  # the server has threads: no fork
        self._counters = Counters.create(self._ctx)
        self._queue: Any = None
        self._process: Any = None
        self._allowed: dict[str, bool] = {}
        self._last_warning = float("-inf")

    # ------------------------------------------------------------------ what it has done
    @property
    def alive(self) -> bool:
        """False once the writer process has ended by itself (a write failed, it was killed)."""
        return self._process is not None and self._process.is_alive()

    @property
    def exit_code(self) -> int | None:
        return self._process.exitcode if self._process is not None else None

    @property
    def files(self) -> list[Path]:
        return [split_name(self.path, i) for i in range(self._counters.parts.value)]

    @property
    def messages(self) -> int:
        return self._counters.messages.value

    @property
    def failed(self) -> int:
        return self._counters.failed.value

    @property
    def bytes(self) -> int:
        return self._counters.bytes.value

    # ------------------------------------------------------------------ loop side
    def start(self) -> None:
        """Check the path (an unwritable one fails here, before anything records), start the
        writer, then tap the bus, latched topics' current messages first."""
        if self.path.suffix != ".mcap":
            raise ValueError(f"cannot record to {self.path}: the name must end in .mcap")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.path.open("wb").close()
        except OSError as exc:
            raise ValueError(f"cannot record to {self.path}: {exc.strerror or exc}") from None
        self._counters.parts.value = 1
        self._queue = self._ctx.Queue()
        self._process = self._ctx.Process(
            target=run_writer, name="mcap-writer", daemon=True,
            args=(str(self.path), self.split_size, self.flush_period, self._queue,
                  self._counters))
        self._process.start()
        self.bus.taps.append(self)
        started = self.bus.clock()
        for topic in list(self.bus.topics.values()):
            if topic.latched and topic.last is not None:
                self._enqueue(topic.last, log_time=started)
        log.info("recording to %s", self.path)

    async def stop(self) -> None:
        """Untap, let the writer write what is queued and finish the file (summary, index)."""
        if self._process is None:
            return
        if self in self.bus.taps:
            self.bus.taps.remove(self)
        process, self._process = self._process, None
        if process.is_alive():
            self._queue.put(None)
        else:  # nobody reads the queue any more: do not wait for it to be written
            self._queue.cancel_join_thread()
        self._queue.close()
        await asyncio.to_thread(self._queue.join_thread)
        await asyncio.to_thread(process.join)
        log.info("recording finished: %s (%d messages, %d dropped, %d not encodable)",
                 ", ".join(map(str, self.files)), self.messages, self.dropped, self.failed)

    def message(self, message: Message) -> None:
        allowed = self._allowed.get(message.topic.name)
        if allowed is None:
            allowed = self._allowed[message.topic.name] = self.filter.allows(message.topic.name)
        if allowed:
            self._enqueue(message)
        origin = message.origin
        if origin is not None and origin.node.startswith(CLIENT_NODE_PREFIX) and any(
            not node.startswith(CLIENT_NODE_PREFIX)
            for node, _cb in message.topic.subscribers.values()
        ):  # a client's publish that reaches a server node
            topic = message.topic
            self._audit(ClientOp.of("publish", topic.name, topic.type_name, origin,
                                    self.bus.clock()))

    def client_op(self, op: ClientOp) -> None:
        if op.op == "call_service" and op.name.startswith(READ_ONLY_SERVICES):
            return
        self._audit(op)

    def _audit(self, op: ClientOp) -> None:
        """A client op that changes the robot, onto the audit channel."""
        entry = json.dumps({"op": op.op, "name": op.name, "type": op.type_name,
                            "client": op.node, "address": op.peer,
                            "auth_level": op.auth_level, "time": op.stamp}).encode()
        ns = int(op.stamp * 1e9)
        self._put(Item(AUDIT_TOPIC, "", False, ns, ns, 0, None, entry, ITEM_OVERHEAD + len(entry)))

    def _enqueue(self, message: Message, log_time: float | None = None) -> None:
        topic = message.topic
        stamp = int(message.stamp * 1e9)
        cdr = message.cdr_bytes
        size = ITEM_OVERHEAD + (len(cdr) if cdr is not None else estimate_size(message.msg))
        when = stamp if log_time is None else int(log_time * 1e9)
        self._put(Item(topic.name, topic.type_name, topic.latched, when, stamp, message.seq,
                       None if cdr is not None else message.msg, cdr, size))

    def _put(self, item: Item) -> None:
        counters = self._counters
        if counters.queued.value - counters.taken.value + item.size <= self.max_queued_bytes:
            counters.queued.value += item.size
            self._queue.put_nowait(item)
            return
        self.dropped += 1
        now = time.monotonic()
        if now - self._last_warning >= WARN_PERIOD:
            self._last_warning = now
            log.warning("recording to %s cannot keep up: %d messages dropped so far",
                        self.path, self.dropped)

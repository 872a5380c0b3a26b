"""``--record FILE.mcap``: every bus message into an MCAP file (ROS 2 profile), off the loop.

The recorder is a bus tap: on the event loop it filters the topic and appends the message to a
batch as bytes it already has: its CDR if someone made it, else the client's own JSON of a
publish, else a pickle of the message. Every ``BATCH_PERIOD`` (or ``BATCH_BYTES``) the batch
goes to the writer process (:mod:`hitrobot_server.record.writer`) down a pipe as one frame of
the messages' own bytes (:mod:`.handoff`), written by the loop itself with ``writev`` when the
pipe takes it (:class:`PipeFeed`): a message costs the loop a header and two appends; nothing is
copied into a batch buffer, and no feeder thread contends with the loop for the interpreter
lock, as a ``multiprocessing.Queue``'s did. The writer encodes what is not CDR yet and writes
chunked, zstd-compressed MCAP.

Who encodes a client's publish of a flat type (``Ros2Codec.direct``; a 720-range LaserScan:
15 µs from the parsed message, 40 µs from the JSON with the parse): the writer, on the other
core, while it keeps up; the loop costs the server's bottleneck, and encoding there cost the
fan-out to one subscriber 20 % (bench/bench_record.py). Once more than ``1/BEHIND`` of the queue
bound waits for the writer, the loop encodes it (once: Zenoh and Foxglove reuse the bytes), and
the writer gets the kind it writes cheapest until it has caught up.

What is queued is bounded in bytes; when the disk cannot keep up, new messages are dropped,
counted, and a warning is logged. The writer closes and flushes the current chunk at least every
``flush_period`` (0.5 s), so a recording whose server is killed with SIGKILL reads back to within
its last second. Client ops that change the robot go on ``/hitrobot/audit`` as
``hitrobot_msgs/AuditEntry`` messages.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import multiprocessing
import os
import pickle
import struct
import time
from collections import deque
from pathlib import Path
from typing import Any

from ..bus.cdr import codec_for
from ..bus.core import Bus
from ..bus.demand import FULL
from ..bus.names import CLIENT_NODE_PREFIX, GlobFilter
from ..bus.tap import ClientOp
from ..bus.topics import Message
from ..wire.memo import PUBLISHED_JSON
from .files import check_writable, split_name
from .handoff import CDR, JSON, MSG, BatchBuilder
from .profile import AUDIT_TOPIC, AUDIT_TYPE
from .writer import Counters, Plan, run_writer

log = logging.getLogger(__name__)

MAX_QUEUED_BYTES = 64 * 1024 * 1024
ITEM_OVERHEAD = 256  # each queued message counts its bytes and this (bounds their number)
FLUSH_PERIOD = 0.5  # seconds between closed chunks (a crash loses at most about this)
BATCH_PERIOD = 0.05  # seconds a message waits on the loop before its batch goes to the writer
BATCH_BYTES = 1024 * 1024  # a batch this big goes at once
LOOP_CDR_BYTES = 256 * 1024
"""While the writer is behind, a client's publish op up to this long, of a flat type, is
encoded on the loop; a longer one is left to the writer (no loop stall)."""
BEHIND = 8
"""The writer is behind when more than 1/BEHIND of the queue bound waits for it."""
WARN_PERIOD = 5.0
READ_ONLY_SERVICES = "/rosapi/"
"""Services under this prefix only read the graph: a client calling them is not audited."""


def known_bytes(message: Message) -> tuple[int, Any]:
    """The message as the writer takes it, without encoding anything: its CDR if someone made
    it, else the client's own ``publish`` op when its ``msg`` is the message as it is (its memo's
    ``PUBLISHED_JSON``, put by its publisher), else the message."""
    if message.cdr_bytes is not None:
        return CDR, message.cdr_bytes
    text = PUBLISHED_JSON.peek(message)
    return (JSON, text) if text is not None else (MSG, message.msg)


class Recorder:
    """Records the bus into ``path`` from :meth:`start` to :meth:`stop`."""

    def __init__(
        self,
        bus: Bus,
        path: Path | str,
        *,
        topics: str | None = None,
        split_size: int = 0,
        split_time: float = 0.0,
        max_disk: int = 0,
        budget_folder: Path | None = None,
        exclusive: bool = False,
        max_queued_bytes: int = MAX_QUEUED_BYTES,
        flush_period: float = FLUSH_PERIOD,
        max_chunks: int = 0,
    ):
        """``exclusive``: refuse a file that exists (a client's name) rather than empty it
        (``--record FILE``, the operator's); ``max_chunks``: per file (0: writer.MAX_CHUNKS)."""
        self.bus = bus
        self.path = Path(path)
        self.plan = Plan(self.path, exclusive, split_size, split_time, flush_period, max_disk,
                         budget_folder, max_chunks)
        self.filter = GlobFilter.parse(topics)
        self.max_queued_bytes = max_queued_bytes
        self.dropped = 0
        self._ctx = multiprocessing.get_context("spawn")  # the server has threads: no fork
        self._counters = Counters.create(self._ctx)
        self._feed: PipeFeed | None = None
        self._process: Any = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._batch = BatchBuilder()
        self._in_pipe = 0  # bytes counted as handed over and not yet taken, at the last look
        self._behind = max_queued_bytes // BEHIND
        self._timer: asyncio.TimerHandle | None = None
        self._topics: dict[str, tuple[str, int | None]] = {}  # name: (type, number if kept)
        self._numbers = itertools.count()  # a topic's number in the hand-off, never reused
        self._audit_number: int | None = None
        self._codec = codec_for(bus.types)
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

    @property
    def disk_error(self) -> int:
        """The errno of the disk error that ended the recording (0: none)."""
        return self._counters.error.value

    # ------------------------------------------------------------------ loop side
    def start(self) -> None:
        """Check the path (a folder that cannot be written, a full disk, a name taken or a
        symlink are refused here, before anything records: ValueError), start the writer,
        then tap the bus, latched topics' current messages first."""
        if self.path.suffix != ".mcap":
            raise ValueError(f"cannot record to {self.path}: the name must end in .mcap")
        check_writable(self.path, exclusive=self.plan.exclusive)
        self._counters.parts.value = 1
        reading, writing = self._ctx.Pipe(duplex=False)
        self._process = self._ctx.Process(
            target=run_writer, name="mcap-writer", daemon=True,
            args=(self.plan, reading, self._counters))
        self._process.start()
        reading.close()  # the writer's end: the pipe ends (EOF) when the server's does
        try:
            self._loop = asyncio.get_running_loop()
        except RuntimeError:
            self._loop = None  # no loop: each message goes at once
        self._feed = PipeFeed(writing, self._loop)
        self.bus.taps.append(self)
        self.bus.demand.taps_changed()
        started = self.bus.clock()
        for topic in list(self.bus.topics.values()):
            if topic.latched and topic.last is not None and self.filter.allows(topic.name):
                number = self._topic(topic.name, topic.type_name, True)[1]
                self._enqueue(topic.last, number, log_time=started)  # type: ignore[arg-type]
        log.info("recording to %s", self.path)

    async def stop(self) -> None:
        """Untap, let the writer write what is queued and finish the file (summary, index)."""
        if self._process is None:
            return
        if self in self.bus.taps:
            self.bus.taps.remove(self)
            self.bus.demand.taps_changed()
        self._hand_off()
        process, self._process = self._process, None
        feed = self._feed
        if feed is not None:
            if process.is_alive():  # what is queued, then the end; a dead writer reads nothing
                feed.send()  # an empty frame: the end
                await feed.drain(process.is_alive)
            feed.close()
        await asyncio.to_thread(process.join)
        log.info("recording finished: %s (%d messages, %d dropped, %d not encodable)",
                 ", ".join(map(str, self.files)), self.messages, self.dropped, self.failed)

    def demand(self, name: str) -> float | None:
        """A recording keeps every message of its topics: they are polled at full rate."""
        return FULL if self.filter.allows(name) else None

    def message(self, message: Message) -> None:
        topic = message.topic
        known = self._topics.get(topic.name)
        if known is None or known[0] != topic.type_name:
            known = self._topic(topic.name, topic.type_name, self.filter.allows(topic.name))
        if known[1] is not None:
            self._enqueue(message, known[1])
        origin = message.origin
        if origin is not None and origin.node.startswith(CLIENT_NODE_PREFIX) and any(
            not node.startswith(CLIENT_NODE_PREFIX) for node, _cb in topic.subscribers.values()
        ):  # a client's publish that reaches a server node
            self._audit(ClientOp.of("publish", topic.name, topic.type_name, origin,
                                    self.bus.clock()))

    def client_op(self, op: ClientOp) -> None:
        if op.op == "call_service" and op.name.startswith(READ_ONLY_SERVICES):
            return
        self._audit(op)

    def _audit(self, op: ClientOp) -> None:
        """A client op that changes the robot, onto the audit channel (CDR, made here: rare)."""
        secs = int(op.stamp)
        entry = {"op": op.op, "name": op.name, "type": op.type_name, "client": op.node,
                 "address": op.peer, "auth_level": op.auth_level or "",
                 "token_name": op.who, "role": op.role,
                 "stamp": {"secs": secs, "nsecs": int((op.stamp - secs) * 1e9)}}
        data = self._codec.encode(entry, self.bus.types.msg(AUDIT_TYPE))
        ns = int(op.stamp * 1e9)
        if self._audit_number is None:  # its own number: a bus topic of that name is not it
            self._audit_number = self._number(AUDIT_TOPIC, AUDIT_TYPE)
        self._put(self._audit_number, CDR, False, ns, ns, 0, data)

    def _number(self, name: str, type_name: str) -> int:
        """A new number for a topic, named to the writer in the batch before its first
        message."""
        number = next(self._numbers)
        self._batch.define(number, name, type_name)
        return number

    def _topic(self, name: str, type_name: str, kept: bool) -> tuple[str, int | None]:
        """A topic seen for the first time (or with a new type): numbered when it is kept."""
        known = self._topics[name] = (type_name, self._number(name, type_name) if kept else None)
        return known

    def _enqueue(self, message: Message, number: int, log_time: float | None = None) -> None:
        kind, data = known_bytes(message)
        if kind == JSON:
            if self._in_pipe > self._behind and len(data) <= LOOP_CDR_BYTES and \
                    self._codec.direct(message.topic.mtype):
                with contextlib.suppress(Exception):  # the writer tries again and counts it
                    kind, data = CDR, message.cdr(self._codec)
        elif kind == MSG:
            data = pickle.dumps(data, pickle.HIGHEST_PROTOCOL)
        stamp = int(message.stamp * 1e9)
        self._put(number, kind, message.topic.latched,
                  stamp if log_time is None else int(log_time * 1e9), stamp, message.seq, data)

    def _put(self, number: int, kind: int, latched: bool, log_time: int, publish_time: int,
             seq: int, data: bytes) -> None:
        size = ITEM_OVERHEAD + len(data)
        batch = self._batch
        if self._in_pipe + batch.size + size > self.max_queued_bytes:
            counters = self._counters  # taken only grows: look again before dropping
            self._in_pipe = counters.queued.value - counters.taken.value
            if self._in_pipe + batch.size + size > self.max_queued_bytes:
                self._dropped()
                return
        batch.add(number, kind, latched, log_time, publish_time, seq, data, size)
        if batch.size >= BATCH_BYTES or self._loop is None:
            self._hand_off()
        elif self._timer is None:
            self._timer = self._loop.call_later(BATCH_PERIOD, self._hand_off)

    def _hand_off(self) -> None:
        """The batch to the writer: one frame down the pipe (:class:`PipeFeed`)."""
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if not self._batch.parts or self._feed is None:
            return
        parts, size = self._batch.take()
        counters = self._counters
        counters.queued.value += size
        self._in_pipe = counters.queued.value - counters.taken.value
        self._feed.send(*parts)

    def _dropped(self) -> None:
        self.dropped += 1
        now = time.monotonic()
        if now - self._last_warning >= WARN_PERIOD:
            self._last_warning = now
            log.warning("recording to %s cannot keep up: %d messages dropped so far",
                        self.path, self.dropped)


PIPE_BYTES = 1024 * 1024
"""The pipe's buffer is asked for this size (Linux ``F_SETPIPE_SZ``; 64 kB otherwise): a batch
then goes in one write while the writer keeps up, and the loop does not come back for it."""


WRITEV_PARTS = 512  # parts given to one writev (Linux takes up to 1024)


class PipeFeed:
    """The server's end of the pipe to the writer, in ``multiprocessing.Connection``'s framing
    (the writer reads it with ``recv_bytes``): a frame sent in parts, which are never joined.
    With a loop, written by the loop without blocking, with ``writev``: what the pipe does not
    take now waits here, as the parts themselves (a part cut by a short write as a view of its
    rest), and goes when the pipe is writable. Without one (a recorder used outside a loop),
    written at once, blocking."""

    def __init__(self, conn: Any, loop: asyncio.AbstractEventLoop | None):
        self._conn = conn
        self._loop = loop
        self._fd = conn.fileno()
        self._pending: deque[bytes | memoryview] = deque()
        self._drained: asyncio.Future | None = None
        self.broken = False  # the writer's end is gone: what is sent is dropped
        with contextlib.suppress(OSError, ImportError, AttributeError):  # Linux only
            import fcntl

            fcntl.fcntl(self._fd, fcntl.F_SETPIPE_SZ, PIPE_BYTES)
        if loop is not None:
            os.set_blocking(self._fd, False)

    @staticmethod
    def header(n: int) -> bytes:
        """The length header ``Connection.recv_bytes`` expects before ``n`` bytes."""
        return struct.pack("!i", n) if n <= 0x7FFFFFFF else struct.pack("!iQ", -1, n)

    @property
    def waiting(self) -> int:
        """Bytes handed over that the pipe has not taken yet."""
        return sum(len(part) for part in self._pending)

    def send(self, *parts: bytes) -> None:
        """One frame of ``parts`` (none: an empty frame); they must not change until written."""
        if self.broken:
            return
        if self._loop is None:
            try:
                self._conn.send_bytes(b"".join(parts))
            except OSError:
                self.broken = True
            return
        waiting = bool(self._pending)  # then the loop writes it when the pipe takes more
        self._pending.append(self.header(sum(map(len, parts))))
        self._pending.extend(parts)
        if not waiting:
            self._write_pending()
            if self._pending and not self.broken:
                self._loop.add_writer(self._fd, self._write_pending)

    def _write_pending(self) -> None:
        pending = self._pending
        while pending:
            try:
                written = os.writev(self._fd, list(itertools.islice(pending, WRITEV_PARTS)))
            except BlockingIOError:
                return
            except OSError:
                self._break()
                return
            while written and pending:
                first = pending[0]
                if written >= len(first):
                    written -= len(first)
                    pending.popleft()
                else:
                    pending[0] = memoryview(first)[written:]
                    written = 0
        self._idle()

    def _break(self) -> None:
        self.broken = True
        self._pending.clear()
        self._idle()

    def _idle(self) -> None:
        if self._loop is not None:
            self._loop.remove_writer(self._fd)
        if self._drained is not None and not self._drained.done():
            self._drained.set_result(None)

    async def drain(self, alive: Any) -> None:
        """Until everything is written, or the writer (``alive()`` False) is gone."""
        while self._pending and not self.broken and alive():
            self._drained = asyncio.get_running_loop().create_future()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(asyncio.shield(self._drained), 1.0)

    def close(self) -> None:
        if self._loop is not None and self._pending:
            self._loop.remove_writer(self._fd)
        self._pending.clear()
        self._conn.close()

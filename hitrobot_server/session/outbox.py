"""Per-client send buffer: control frames first, then topics by fair shares of bytes.

rosbridge's classic failure is one slow client growing an unbounded queue until latency is
minutes (rosbridge #765, #889, #989); foxglove_bridge #174 is the next one: a single FIFO puts
the pose behind seconds of images. Here, for each client:

* **Control frames** (``droppable=False``: service responses, statuses, action feedback and
  results) wait in one FIFO that is served before any topic data and is never dropped.
* **Topic data** (``droppable=True``) waits in one queue per *stream* (``key``; a subscription
  passes its topic, a caller that passes none shares the default stream ``None``). The sender
  picks the next frame across streams by deficit round robin over bytes (:data:`QUANTUM` per
  turn), so a stream of small messages is never stuck behind a big one. A group of frames (one
  message's ``fragment`` ops) goes out one frame per pick, interleaved with the other streams;
  once its first frame is out the rest of the group is never dropped.
* All topic data of a client holds at most ``limit`` bytes. Over it, the oldest entries of the
  stream holding the most bytes go first (the topic overflowing its share is thinned; a small
  topic that fits its share loses nothing). A stream may also hold at most ``depth`` entries
  (a subscription's ``queue_length``; 1 = only the latest value). Drops are counted per stream
  (:meth:`drops`) and ``on_thinned(key)`` is called on a stream's first drop.
* An entry may be ``PendingFrames`` (wire/frames.py: a big message or reply being encoded in
  the worker pool, charged at its estimate): its stream waits for it in place while the other
  streams go on.

Interface for transports: ``direct`` (a synchronous write used while nothing is queued: the
fast path), ``get()`` → the next frames to write (or None once closed and drained) then
``sent()``, and ``room`` (an event set while the control bytes are within ``budget``; a transport
reads no input while it is clear: backpressure for a client that does not read its replies).
Interface for producers: ``put(frames, droppable=False, key=None, depth=None)``.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections import deque
from collections.abc import Callable, Hashable
from dataclasses import dataclass

from ..wire.frames import Frame, Frames, PendingFrames
from .traffic import Traffic

DirectWrite = Callable[[list[Frame]], bool]


def held(data: bytes | memoryview) -> int:
    """Bytes one frame keeps alive: a memoryview keeps its whole buffer, not only the part it
    shows (a header's view on a 50 MB message holds the 50 MB)."""
    if data.__class__ is memoryview:
        return max(memoryview(data.obj).nbytes, data.nbytes)  # type: ignore[union-attr]
    return len(data)


def nbytes(frames: Frames) -> int:
    """Bytes a queue charges for frames: what they hold, or a pending set's estimate."""
    if isinstance(frames, PendingFrames):
        return frames.size
    total = 0
    for data, _binary in frames:
        total += len(data) if data.__class__ is bytes else held(data)
    return total


QUANTUM = 16 * 1024
"""Bytes a stream may send per round-robin turn (more if its next frame is bigger)."""


@dataclass(slots=True)
class _Entry:
    frames: Frames
    size: int
    pos: int = 0  # frames of this group already out (the rest must follow: never dropped)


class _Stream:
    __slots__ = ("key", "entries", "bytes", "deficit", "dropped", "depth", "granted")

    def __init__(self, key: Hashable):
        self.key = key
        self.entries: deque[_Entry] = deque()
        self.bytes = 0
        self.deficit = 0
        self.dropped = 0
        self.depth: int | None = None
        self.granted = False  # got its quantum for the current turn


class Outbox:
    """Outgoing frames of one client (see the module docstring)."""

    def __init__(self, limit: int = 10_000_000, budget: int = 0):
        self.limit = limit
        self.budget = budget  # control bytes above which the client's input is not read
        self._control: deque[_Entry] = deque()
        self._control_bytes = 0
        self.peak_control = 0  # the most reply bytes it held at once (see session/heap.py)
        self._streams: dict[Hashable, _Stream] = {}
        self._active: deque[_Stream] = deque()  # streams with entries, in round-robin order
        self._bytes = 0
        self._wakeup = asyncio.Event()
        self.room = asyncio.Event()
        self.room.set()
        self.dropped = 0
        self.closed = False
        self.on_thinned: Callable[[Hashable], None] | None = None
        # Given by the transport (attach_writer): writes frames synchronously when the socket
        # has room and returns False when it has not. Nothing queued and nothing being sent
        # means order is kept, and the common case costs no task switch (2x the fan-out rate).
        self.direct: DirectWrite | None = None
        self.busy = False  # the transport's pump is sending an entry
        self.traffic: Traffic | None = None  # the server's counts per topic (/metrics)

    def attach_writer(self, direct: DirectWrite | None) -> None:
        """The transport's synchronous writer, used while nothing is queued (None: the pump
        sends everything)."""
        self.direct = direct

    @property
    def buffered(self) -> int:
        """Bytes queued, control and topic data."""
        return self._bytes

    @property
    def control_bytes(self) -> int:
        return self._control_bytes

    def __len__(self) -> int:
        return len(self._control) + sum(len(s.entries) for s in self._active)

    def drops(self, key: Hashable = None) -> int:
        """Entries of stream ``key`` dropped so far."""
        stream = self._streams.get(key)
        return stream.dropped if stream is not None else 0

    def put(
        self,
        frames: Frames,
        droppable: bool = False,
        key: Hashable = None,
        depth: int | None = None,
    ) -> bool:
        """Queue frames; returns False when they were dropped (topic data, no room).

        Pending frames are charged at their estimate until they are built. ``key`` and
        ``depth`` place topic data in its stream (ignored for control frames). A message larger
        than the whole limit is still sent when no other topic data is queued, so a big map
        always gets through.
        """
        if self.closed:
            return False
        if droppable and self.traffic is not None:  # metrics hook: topic data, per topic
            self.traffic.count_sent(key, nbytes(frames))
        pending = isinstance(frames, PendingFrames)
        if (not pending and not self._bytes and not self._control and not self._active
                and not self.busy and self.direct is not None and self.direct(frames)):
            return True  # written now by the transport's direct writer (nothing queued before)
        entry = _Entry(frames, nbytes(frames))
        if pending:
            frames.future.add_done_callback(self._ready)
        size = entry.size
        if not droppable:  # a reply, status or feedback: never dropped
            self._control.append(entry)
            self._control_bytes += size
            if self._control_bytes > self.peak_control:
                self.peak_control = self._control_bytes
            self._bytes += size
            if self.budget and self._control_bytes > self.budget:
                self.room.clear()
            self._wakeup.set()
            return True
        stream = self._streams.get(key)  # topic data: into its stream
        if stream is None:
            stream = self._streams[key] = _Stream(key)
        stream.depth = depth
        if depth is not None and depth > 0:
            while len(stream.entries) >= depth and self._drop_oldest(stream):
                pass
        if (self.limit > 0 and self._bytes - self._control_bytes + size > self.limit
                and not self._make_room(stream, size)):
            return False
        if not stream.entries:
            self._active.append(stream)
        stream.entries.append(entry)
        stream.bytes += size
        self._bytes += size
        self._wakeup.set()
        return True

    def _make_room(self, stream: _Stream, size: int) -> bool:
        """Thin the streams over their fair share until ``size`` more bytes of ``stream`` fit;
        False (counted as a drop) when they cannot, because ``stream`` is over its share."""
        streams = len(self._active) + (not stream.entries)
        share = self.limit // streams
        while self._bytes - self._control_bytes + size > self.limit and self._evict(
            share, stream, size
        ):
            pass
        if (
            self._bytes - self._control_bytes + size > self.limit
            and self._bytes > self._control_bytes
            and stream.bytes + size > share
        ):  # a stream within its share is never thinned, even when others can't be
            self._count_drop(stream)
            return False
        return True

    def _ready(self, _future: asyncio.Future) -> None:
        self._wakeup.set()

    def _count_drop(self, stream: _Stream) -> None:
        stream.dropped += 1
        self.dropped += 1
        if self.traffic is not None:  # metrics hook: thinned per topic
            self.traffic.count_thinned(stream.key)
        if stream.dropped == 1 and self.on_thinned is not None:
            self.on_thinned(stream.key)

    def _drop_oldest(self, stream: _Stream) -> bool:
        """Drop the oldest entry of ``stream`` not yet started."""
        for i, entry in enumerate(stream.entries):
            if not entry.pos:
                del stream.entries[i]
                stream.bytes -= entry.size
                self._bytes -= entry.size
                self._count_drop(stream)
                if not stream.entries:
                    self._deactivate(stream)
                return True
        return False

    def _evict(self, share: int, incoming: _Stream, size: int) -> bool:
        """Drop the oldest entry of the stream holding the most bytes over ``share`` (counting
        the entry about to join ``incoming``)."""

        def held(s: _Stream) -> int:
            return s.bytes + size if s is incoming else s.bytes

        for stream in sorted(self._active, key=held, reverse=True):
            if held(stream) <= share:
                return False
            if self._drop_oldest(stream):
                return True
        return False

    def _deactivate(self, stream: _Stream) -> None:
        stream.deficit = 0
        stream.granted = False
        with contextlib.suppress(ValueError):  # already out of the rotation
            self._active.remove(stream)

    def _uncharge_control(self, size: int) -> None:
        self._control_bytes -= size
        self._bytes -= size
        if not self.budget or self._control_bytes <= self.budget:
            self.room.set()

    async def get(self) -> list[Frame] | None:
        """Next frames to write, or None once closed and drained; marks the outbox busy until
        the caller calls ``sent()``."""
        while True:
            self.busy = False
            frames = self._next()
            if frames is not None:
                self.busy = True
                return frames
            if self.closed and not self._control and not self._active:
                return None
            self._wakeup.clear()
            await self._wakeup.wait()

    def _next(self) -> list[Frame] | None:
        """Pick without waiting: the control FIFO first, then deficit round robin."""
        while self._control:
            entry = self._control[0]
            frames = entry.frames
            if isinstance(frames, PendingFrames):
                if not frames.done():
                    break  # control frames keep their order: wait for this one
                frames = frames.frames()
            self._control.popleft()
            self._uncharge_control(entry.size)
            if frames is not None:
                return frames
        if self._control:
            return None
        waiting = 0
        while self._active and waiting < len(self._active):
            stream = self._active[0]
            entry = stream.entries[0]
            if isinstance(entry.frames, PendingFrames):
                if not entry.frames.done():
                    waiting += 1  # its stream waits in place; the others go on
                    self._active.rotate(-1)
                    continue
                frames = entry.frames.frames()
                if frames is None:
                    self._remove_head(stream, entry.size)
                    continue
                real = sum(len(f[0]) for f in frames)
                stream.bytes += real - entry.size
                self._bytes += real - entry.size
                entry.frames, entry.size = frames, real
            waiting = 0
            first = entry.frames[entry.pos]
            cost = len(first[0])
            if not stream.granted:
                stream.granted = True
                stream.deficit += QUANTUM
            if cost > stream.deficit:
                stream.granted = False  # its turn is over; it keeps the deficit earned
                self._active.rotate(-1)
                if len(self._active) > 1:
                    continue
                stream.granted = True
                stream.deficit = max(stream.deficit, cost)  # alone: no one to be fair to
            stream.deficit -= cost
            entry.pos += 1
            if entry.pos < len(entry.frames):
                entry.size -= cost
                stream.bytes -= cost
                self._bytes -= cost
            else:
                self._remove_head(stream, entry.size)
            return [first]
        return None

    def _remove_head(self, stream: _Stream, size: int) -> None:
        stream.entries.popleft()
        stream.bytes -= size
        self._bytes -= size
        if not stream.entries:
            self._deactivate(stream)

    def forget(self, key: Hashable) -> None:
        """Stream ``key`` is no longer wanted (unsubscribed): free what it holds and its count;
        a group already started still goes out whole."""
        stream = self._streams.pop(key, None)
        if stream is None:
            return
        kept = [e for e in stream.entries if e.pos]  # the rest of a started group
        freed = stream.bytes - sum(e.size for e in kept)
        stream.entries = deque(kept)
        stream.bytes -= freed
        self._bytes -= freed
        if kept:
            self._streams[key] = stream
            stream.dropped = 0
        else:
            self._deactivate(stream)

    def sent(self) -> None:
        """The frames from the last ``get()`` are written; direct writes may resume."""
        self.busy = False

    def close(self) -> None:
        """Stop accepting; what is queued is still delivered, then get() returns None."""
        self.closed = True
        self._wakeup.set()
        self.room.set()

    def abort(self, last: list[Frame]) -> None:
        """Drop everything queued, send only ``last`` (a closing status), then close."""
        self.clear()
        self.closed = False
        self.put(last)
        self.close()

    def clear(self) -> None:
        """The connection is gone: free everything queued now (not at the next full GC)."""
        self.close()
        self._control.clear()
        self._active.clear()
        self._streams.clear()
        self._bytes = self._control_bytes = 0
        self.direct = None
        self.on_thinned = None
        self.room.set()

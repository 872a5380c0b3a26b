"""Per-client bounded send buffer.

rosbridge's classic failure is one slow client growing an unbounded queue until latency is
minutes (rosbridge #765, #889, #989). Here every client gets ``limit`` bytes; topic data
beyond that evicts that client's own oldest topic data, and the bus never waits for it.

An entry may be a future of its frames (a big message being encoded in the worker pool): the
pump waits for it in place, so whatever was queued after it still goes out after it.
"""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

log = logging.getLogger(__name__)

Frame = tuple[bytes, bool]  # (payload, is_binary)
Frames = list[Frame] | asyncio.Future  # a future resolves to list[Frame]
DirectWrite = Callable[[list[Frame]], bool]


@dataclass(slots=True)
class _Entry:
    frames: Frames
    size: int
    droppable: bool


class Outbox:
    """Queue of outgoing frame groups; a group (e.g. one message's fragments) goes out whole."""

    def __init__(self, limit: int = 10_000_000):
        self.limit = limit
        self._queue: deque[_Entry] = deque()
        self._bytes = 0
        self._wakeup = asyncio.Event()
        self.dropped = 0
        self.closed = False
        # Set by the transport: writes frames synchronously when the socket has room and
        # returns False when it has not. Nothing queued and nothing being sent means order
        # is kept, and the common case costs no task switch (2x the fan-out rate).
        self.direct: DirectWrite | None = None
        self.busy = False  # the transport's pump is sending an entry

    @property
    def buffered(self) -> int:
        return self._bytes

    def __len__(self) -> int:
        return len(self._queue)

    def put(self, frames: Frames, droppable: bool = False, size: int | None = None) -> bool:
        """Queue frames; returns False when topic data was dropped for lack of room.

        ``size`` is the byte count to charge for a future of frames (an estimate).

        Replies (service responses, status, action results) are never dropped: they are
        small and a lost reply would hang the caller. A message larger than the whole
        limit is still sent when the buffer is empty, so a big map always gets through.
        """
        if self.closed:
            return False
        pending = isinstance(frames, asyncio.Future)
        if (
            not pending
            and not self._queue
            and not self.busy
            and self.direct is not None
            and self.direct(frames)
        ):
            return True
        if not pending:
            size = sum(len(f[0]) for f in frames)
        elif size is None:
            size = 0
        if droppable and self.limit > 0:
            while self._bytes + size > self.limit and self._drop_oldest():
                pass
            if self._bytes + size > self.limit and self._queue:
                self.dropped += 1
                return False
        self._queue.append(_Entry(frames, size, droppable))
        self._bytes += size
        self._wakeup.set()
        return True

    def _drop_oldest(self) -> bool:
        for i, entry in enumerate(self._queue):
            if entry.droppable:
                del self._queue[i]
                self._bytes -= entry.size
                self.dropped += 1
                return True
        return False

    async def get(self) -> list[Frame] | None:
        """Next frame group, or None once closed and drained; marks the outbox busy until
        the caller calls ``sent()``. A future entry is awaited here, in its place."""
        while True:
            self.busy = False
            while not self._queue:
                if self.closed:
                    return None
                self._wakeup.clear()
                await self._wakeup.wait()
            self.busy = True
            entry = self._queue.popleft()
            self._bytes -= entry.size
            if not isinstance(entry.frames, asyncio.Future):
                return entry.frames
            try:  # shielded: the future is shared by every subscriber of the message
                return await asyncio.shield(entry.frames)
            except asyncio.CancelledError:
                if not entry.frames.cancelled():
                    raise  # this pump was cancelled, not the encode
            except Exception:
                log.exception("encoding a big message failed; it is skipped for this client")

    def sent(self) -> None:
        """The frames from the last ``get()`` are written; direct writes may resume."""
        self.busy = False

    def close(self) -> None:
        """Stop accepting; what is queued is still delivered, then get() returns None."""
        self.closed = True
        self._wakeup.set()

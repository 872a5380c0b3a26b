"""WebSocket control frames cost what data frames cost (issue 52).

The websockets library answers a client's ping itself, inside ``data_received``: the pong goes
to the socket's write buffer whether or not the client reads it, and reading goes on whatever
the client sends, since only data frames pause it. A client that sends pings without reading
the pongs (two million in ten seconds) made the server hold every pong (+478 MB) and spend
whole turns of its loop parsing them. Here the connection watches its control frames:

- **their rate**: :data:`~..session.core.CONTROL_FRAMES_PER_SECOND` pings (and unsolicited
  pongs) a second; past it the client's input is not read until the second is over, so a
  flooder is slowed to one read (16 kB, :data:`.connection.READ_BYTES`) a second;
- **the pongs it has not read**: past :data:`~..session.core.BEHIND_BYTES` of them in the
  write buffer its input is not read until it reads them (the buffer drains), as a client
  over its reply bound is no longer read.

Either way what a flooder costs is bounded by one read and the bytes the bound allows; the
other clients are served meanwhile. ``ControlBudget`` is the count (sans-I/O);
``ControlledConnection`` applies it to a websockets ``ServerConnection``.
"""

from __future__ import annotations

import asyncio
from typing import Any

from websockets.asyncio.server import ServerConnection
from websockets.frames import Frame, Opcode

from ..session.core import BEHIND_BYTES, CONTROL_FRAMES_PER_SECOND

PONG_OVERHEAD = 2
"""Bytes of a server's pong besides its payload (unmasked, payload ≤ 125 bytes)."""


class ControlBudget:
    """One client's control frames in the current second and the pong bytes it was sent since
    its write buffer last drained."""

    def __init__(self) -> None:
        self.since = float("-inf")  # start of the current second
        self.count = 0
        self.pong_bytes = 0

    def frame(self, now: float, pong_bytes: int = 0) -> bool:
        """Count one control frame (answered with ``pong_bytes``); whether the rate is over."""
        if now - self.since >= 1.0:
            self.since, self.count = now, 0
        self.count += 1
        self.pong_bytes += pong_bytes
        return self.count > CONTROL_FRAMES_PER_SECOND

    def behind(self, buffered: int) -> bool:
        """Whether the client has more than :data:`BEHIND_BYTES` of pongs unread, the write
        buffer holding ``buffered`` bytes."""
        return min(self.pong_bytes, buffered) > BEHIND_BYTES

    def drained(self) -> None:
        self.pong_bytes = 0


class ControlledConnection(ServerConnection):
    """A ``ServerConnection`` whose reading stops while any of its holds is on: the
    library's own (its queue of messages is full), the rate's or the unread pongs'."""

    _timer: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        super().connection_made(transport)
        self._holds: set[str] = set()
        self._budget = ControlBudget()
        queue = self.recv_messages  # the library pauses reading here; it becomes one hold
        queue.pause, queue.resume = (lambda: self._hold("queue"),
                                     lambda: self._release("queue"))

    def _hold(self, why: str) -> None:
        if not self._holds:
            self.transport.pause_reading()
        self._holds.add(why)

    def _release(self, why: str) -> None:
        if why in self._holds:
            self._holds.discard(why)
            if not self._holds and not self.transport.is_closing():
                self.transport.resume_reading()

    def process_event(self, event: Any) -> None:
        if isinstance(event, Frame) and event.opcode in (Opcode.PING, Opcode.PONG):
            answered = event.opcode is Opcode.PING
            if answered or bytes(event.data) not in self.pending_pings:
                pong = len(event.data) + PONG_OVERHEAD if answered else 0
                if self._budget.frame(self.loop.time(), pong) and "rate" not in self._holds:
                    self._hold("rate")
                    self._timer = self.loop.call_at(self._budget.since + 1.0,
                                                    self._release, "rate")
        super().process_event(event)

    def data_received(self, data: bytes) -> None:
        super().data_received(data)
        if self._budget.behind(self.transport.get_write_buffer_size()):
            self._hold("unread")

    def resume_writing(self) -> None:
        super().resume_writing()
        self._budget.drained()  # the buffer is under its low mark: the client reads
        self._release("unread")

    def connection_lost(self, exc: Exception | None) -> None:
        if self._timer is not None:
            self._timer.cancel()
        super().connection_lost(exc)

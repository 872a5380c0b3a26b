"""A WebSocket connection that hands what it read to the WebSocket parser a slice at a time.

The parser handles every frame of one read in one go. asyncio's socket transports can be told
to read less (``connection.limit_read``); uvloop's cannot, and read up to 256 kB: 12,000 frames
of junk or of bogus 16-byte service calls parsed while every other client waits (about half a
second on a busy machine). Here a read longer than :data:`~.connection.READ_BYTES` is parsed
in slices of that size, one per turn of the loop, and the socket is not read meanwhile once
:data:`BACKLOG_BYTES` wait (what websockets' own flow control pauses stays paused).
"""

from __future__ import annotations

import asyncio

from websockets.asyncio.server import ServerConnection

from .connection import READ_BYTES

BACKLOG_BYTES = 64 * 1024
"""Bytes read but not yet parsed past which the socket is not read until they are."""


class SlicedConnection(ServerConnection):
    _backlog: bytearray | None = None
    _drain: asyncio.Handle | None = None
    _paused = False  # reading paused here (not by websockets' flow control)

    def data_received(self, data: bytes) -> None:
        if self._backlog is None and len(data) <= READ_BYTES:
            super().data_received(data)  # the common case: nothing waits, a short read
            return
        if self._backlog is None:
            self._backlog = bytearray()
        self._backlog += data
        if len(self._backlog) > BACKLOG_BYTES and not self._paused:
            self._paused = True
            self.transport.pause_reading()
        if self._drain is None:
            self._next_slice()

    def _next_slice(self) -> None:
        """Parse one slice of what waits; the next on the loop's next turn."""
        self._drain = None
        backlog = self._backlog
        if backlog is None:
            return
        piece = bytes(backlog[:READ_BYTES])
        del backlog[:READ_BYTES]
        if not backlog:
            self._backlog = None
            if self._paused:
                self._paused = False
                if not self.recv_messages.paused:
                    self.transport.resume_reading()
        else:
            self._drain = asyncio.get_running_loop().call_soon(self._next_slice)
        super().data_received(piece)

    def _flush(self) -> None:
        """Everything that waits, parsed now (the end of the stream comes after it)."""
        if self._drain is not None:
            self._drain.cancel()
            self._drain = None
        backlog, self._backlog = self._backlog, None
        if backlog:
            super().data_received(bytes(backlog))

    def eof_received(self) -> bool | None:
        self._flush()
        return super().eof_received()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._drain is not None:  # the peer is gone: what it sent last is not parsed
            self._drain.cancel()
            self._drain = None
        self._backlog = None
        super().connection_lost(exc)

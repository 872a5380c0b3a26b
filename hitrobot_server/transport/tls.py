"""TLS handshakes, bounded: how many may be in progress (server-wide and per source address),
and how long each may take.

asyncio's own TLS server starts a handshake for every connection it accepts, holds about
300 KiB for each until it finishes, and gives up only after 60 s: 2,000 connections that never
finish their handshake held +604 MiB. Both ports (WebSocket and TCP) therefore accept plain
TCP and upgrade it here, with ``loop.start_tls``: a connection beyond either cap is closed at
once, before any TLS state exists, and a handshake not done within ``timeout`` is dropped.
"""

from __future__ import annotations

import asyncio
import logging
import ssl
from dataclasses import dataclass, field

log = logging.getLogger(__name__)


@dataclass
class HandshakeGate:
    """The TLS context of a server and its bounds on handshakes in progress (one gate for
    both ports, so the caps hold for the server as a whole)."""

    context: ssl.SSLContext
    timeout: float = 5.0
    limit: int = 64
    per_address: int = 8
    in_progress: int = 0
    _by_address: dict[str, int] = field(default_factory=dict)
    _tasks: set[asyncio.Task] = field(default_factory=set)
    _refused_logged: float = float("-inf")

    def admit(self, address: str) -> bool:
        """Take a place for a handshake from ``address``; False (and nothing taken) when the
        server or that address already has as many in progress as allowed."""
        if self.in_progress >= self.limit or self._by_address.get(address, 0) >= self.per_address:
            now = asyncio.get_running_loop().time()
            if now - self._refused_logged >= 10.0:  # a flood must not flood the log too
                self._refused_logged = now
                log.warning("TLS: connection from %s closed: %d handshakes in progress (%d from "
                            "that address; limits %d and %d)", address or "?", self.in_progress,
                            self._by_address.get(address, 0), self.limit, self.per_address)
            return False
        self.in_progress += 1
        self._by_address[address] = self._by_address.get(address, 0) + 1
        return True

    def release(self, address: str) -> None:
        self.in_progress -= 1
        left = self._by_address.get(address, 0) - 1
        if left > 0:
            self._by_address[address] = left
        else:
            self._by_address.pop(address, None)

    async def upgrade(self, transport: asyncio.Transport, protocol: asyncio.BaseProtocol,
                      address: str) -> asyncio.Transport | None:
        """Run the server side of the handshake on an admitted connection; the TLS transport,
        or None (the connection closed) when it failed or took longer than ``timeout``."""
        loop = asyncio.get_running_loop()
        try:
            return await loop.start_tls(transport, protocol, self.context, server_side=True,
                                        ssl_handshake_timeout=self.timeout)
        except (OSError, ssl.SSLError, TimeoutError, ConnectionError, EOFError) as exc:
            log.debug("TLS handshake with %s failed: %s", address or "?", exc)
            transport.abort()
            return None
        finally:
            self.release(address)

    def spawn(self, coro) -> asyncio.Task:
        """Run a handshake task that :meth:`close` cancels when the server stops."""
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    def close(self) -> None:
        for task in list(self._tasks):
            task.cancel()


def peer_address(transport: asyncio.BaseTransport) -> str:
    peer = transport.get_extra_info("peername")
    return str(peer[0]) if peer else ""

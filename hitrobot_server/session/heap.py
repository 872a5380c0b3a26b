"""Memory a big client made the server hold, given back to the system once it has left.

glibc's malloc keeps what Python frees in its heap for reuse: after a Foxglove client that
never read its replies (98 ``getParameters`` of 15 MB, disconnected at twice its reply budget)
left, about 170 MB stayed resident although nothing referred to it any more.
``malloc_trim(0)`` hands the free pages back. It runs a second after a client that held more
than :data:`TRIM_AFTER_BYTES` of replies leaves, at most once per :data:`TRIM_EVERY` seconds,
and only where the C library is glibc (elsewhere nothing is done).
"""

from __future__ import annotations

import asyncio
import ctypes
import logging
import os
from collections.abc import Callable
from typing import Protocol

from .outbox import Outbox

log = logging.getLogger(__name__)

TRIM_AFTER_BYTES = 8 * 1024 * 1024
"""Reply bytes a client held at once past which its leaving trims the heap."""
TRIM_DELAY = 1.0
"""Seconds after the client left: its connection's buffers are freed by then."""
TRIM_EVERY = 10.0
"""Least seconds between two trims (each walks the whole heap: a few ms)."""


class HasOutbox(Protocol):
    outbox: Outbox


def glibc_trim() -> Callable[[int], int] | None:
    """glibc's ``malloc_trim``, or None when the C library is another (musl, macOS)."""
    try:
        if not os.confstr("CS_GNU_LIBC_VERSION"):
            return None
        return ctypes.CDLL("libc.so.6").malloc_trim
    except (ValueError, OSError, AttributeError):
        return None


class HeapTrim:
    """One per server: trims the heap after big clients leave (see the module docstring)."""

    def __init__(self) -> None:
        self._trim = glibc_trim()
        self._last = float("-inf")
        self._pending: asyncio.TimerHandle | None = None

    def client_left(self, client: HasOutbox) -> None:
        if self._trim is None or client.outbox.peak_control < TRIM_AFTER_BYTES:
            return
        if self._pending is not None:  # one trim will do for every client gone meanwhile
            return
        loop = asyncio.get_running_loop()
        delay = max(TRIM_DELAY, self._last + TRIM_EVERY - loop.time())
        self._pending = loop.call_later(delay, self._run, client.outbox.peak_control)

    def _run(self, held: int) -> None:
        self._pending = None
        if self._trim is None:
            return
        self._last = asyncio.get_running_loop().time()
        self._trim(0)
        log.info("heap trimmed after a client that held %.0f MB of replies left",
                 held / 1e6)

    def close(self) -> None:
        if self._pending is not None:
            self._pending.cancel()
            self._pending = None

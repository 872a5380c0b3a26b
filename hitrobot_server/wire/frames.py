"""Frames as an outbox holds them, whatever the wire protocol: ready (a list), or
:class:`PendingFrames` being built away from the event loop (the worker pool), which the outbox
waits for in place. Each protocol's package builds its own (session/rosbridge/frames.py)."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable

log = logging.getLogger(__name__)

Frame = tuple[bytes, bool]  # (payload, is_binary)

Run = Callable[..., Awaitable[list[Frame]]]
"""Runs ``fn(*args)`` away from the event loop (the server's ``WorkerPool.run``,
session/offload.py)."""


class PendingFrames:
    """Frames being built away from the event loop, and the bytes they are charged at until
    then (an estimate). A queue holding one waits for it in place."""

    __slots__ = ("future", "size")

    def __init__(self, future: asyncio.Future[list[Frame]], size: int):
        self.future = future
        self.size = size

    def done(self) -> bool:
        return self.future.done()

    def ok(self) -> bool:
        """Done, with frames (not failed, not cancelled)."""
        f = self.future
        return f.done() and not f.cancelled() and f.exception() is None

    def frames(self) -> list[Frame] | None:
        """The frames once done; None (logged) when building them failed or was cancelled."""
        if self.future.cancelled():
            return None
        exc = self.future.exception()
        if exc is not None:
            log.error("encoding a big message failed; it is skipped for this client: %r", exc)
            return None
        return self.future.result()


Frames = list[Frame] | PendingFrames
"""One message's or reply's frames as a queue holds them: ready, or pending."""

"""What every client session is, whatever its wire protocol (rosbridge, Foxglove): its identity
on the bus, its outbox, the limits on its reports and unread replies, the tasks tied to it, and
what it gives back when it goes. A session holds one :class:`ClientCore` and delegates to it;
only how an error status is spelled differs between the protocols (``error_frames``).

The protections: how many reports of bad input and error statuses one client gets per second,
so a flood of junk or bogus ops cannot flood the client, the log or the server's memory; and
the hard bound on the replies a client leaves unread, past which it is disconnected; and what a
client's WebSocket control frames may cost (applied by the transport)."""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Coroutine
from typing import Any

from ..bus.core import Bus
from ..bus.names import CLIENT_NODE_PREFIX
from ..bus.topics import Origin
from ..wire.frames import Frames
from .options import SessionOptions
from .outbox import Outbox, nbytes

log = logging.getLogger(__name__)

STREAM_ERRORS_PER_SECOND = 10
"""Most reports per second of unparseable TCP input that belongs to no op (garbage)."""

ERROR_STATUSES_PER_SECOND = 50
"""Most error statuses per second queued for a client that does not keep up with its replies
(:data:`BEHIND_BYTES` unread); the rest are counted and reported in one line, so a flood of
bogus ops cannot make the server hold a flood of errors."""
BEHIND_BYTES = 64 * 1024

CONTROL_FRAMES_PER_SECOND = 100
"""Most WebSocket pings (and pongs nobody asked for) one client may send a second: a keepalive
sends one every few seconds; past it the client's input waits for the next second
(transport/control.py), as its pongs wait once :data:`BEHIND_BYTES` of them are unread."""


class ReportLimits:
    """The per-second counts of one client's garbage reports and error statuses; ``say``
    queues one error status (in the client's protocol) saying how many were left out."""

    def __init__(self, outbox: Outbox, say: Callable[[str], None]):
        self.outbox = outbox
        self.say = say
        self._garbage_since = float("-inf")  # start of the current second of stream errors
        self._garbage = 0
        self._errors_since = float("-inf")  # start of the current second of error statuses
        self._errors = 0
        self._errors_skipped = 0

    def garbage(self, now: float) -> int:
        """Count one piece of garbage; how many there were in the current second."""
        if now - self._garbage_since >= 1.0:
            self._garbage_since, self._garbage = now, 0
        self._garbage += 1
        return self._garbage

    def skip_error(self, now: float) -> bool:
        """Whether to leave out this error status (see :data:`ERROR_STATUSES_PER_SECOND`)."""
        if now - self._errors_since >= 1.0:
            if self._errors_skipped:
                self.say(f"{self._errors_skipped} more error status(es) in the last second "
                         "not sent: this client does not read its replies fast enough")
            self._errors_since, self._errors, self._errors_skipped = now, 0, 0
        self._errors += 1
        if self._errors <= ERROR_STATUSES_PER_SECOND or self.outbox.control_bytes < BEHIND_BYTES:
            return False
        self._errors_skipped += 1
        return True


def over_reply_bound(outbox: Outbox, limit: int) -> str | None:
    """Why a client must be disconnected, once its unread replies are past twice
    ``--reply-buffer-limit`` (None while they are not): the caller aborts its outbox with a
    last status saying so (and the WebSocket close reason)."""
    if not limit or outbox.control_bytes <= 2 * limit or outbox.closed:
        return None
    return (f"disconnected: {outbox.control_bytes} bytes of replies not read "
            f"(over twice --reply-buffer-limit {limit})")


def replies_full(outbox: Outbox, limit: int, calls: int, mean_reply: float) -> bool:
    """Whether a new request must be refused: this client's unread replies, and those its
    ``calls`` in flight will bring (at ``mean_reply`` bytes each), are over the budget (the
    transport has stopped reading its input, but one read may hold many requests)."""
    return bool(limit) and outbox.control_bytes + calls * mean_reply > limit



class ClientCore:
    """One client's identity, outbox, report and reply limits, tasks and release."""

    def __init__(self, bus: Bus, settings: SessionOptions, name: str, peer: str,
                 error_frames: Callable[[str], Frames]):
        """``name``: the client's own part of its node name (a number, ``foxglove_3``);
        ``error_frames``: an error status in the client's protocol."""
        self.bus = bus
        self.peer = peer
        self.node = f"{CLIENT_NODE_PREFIX}{settings.client_tag}{name}"
        # who sends: admin without --authenticate, no role until it authenticates
        self.origin = Origin(self.node, peer=peer, role="none" if settings.authenticate
                             else "admin")
        self.reply_limit = settings.reply_buffer_limit
        self.outbox = Outbox(settings.send_buffer_limit, settings.reply_buffer_limit)
        self.outbox.on_thinned = self._thinned
        self._error_frames = error_frames
        self.limits = ReportLimits(self.outbox, lambda text: self.notice(error_frames(text)))
        self.reply_bytes = 0.0  # running mean size of its replies: what a call will cost
        self.closed = False
        self.close_reason = ""  # why the server closed the connection, if it did
        self.on_close: list[Callable[[Any], None]] = []  # the server's: run once at release
        self.tasks: set[asyncio.Task] = set()
        bus.register_node(self.node)

    # ------------------------------------------------------------------ replies
    def reply(self, frames: Frames) -> None:
        """Queue a reply (never dropped by the send bound), counted in the mean reply size."""
        charged = nbytes(frames)  # a big reply being built in the worker pool: its estimate
        self.notice(frames)
        self.reply_bytes += (charged - self.reply_bytes) / 8

    def notice(self, frames: Frames) -> None:
        """Queue a status or announcement like a reply; past twice ``--reply-buffer-limit``
        of unread replies the client is disconnected: its queue is freed, and a last status
        (and the WebSocket close reason) says why."""
        self.outbox.put(frames)
        reason = over_reply_bound(self.outbox, self.reply_limit)
        if reason is None:
            return
        log.warning("client %s (%s): %s", self.node, self.peer or "?", reason)
        self.close_reason = reason
        self.outbox.abort(self._error_frames(reason))

    def skip_error(self) -> bool:
        """Whether to leave out this error status (:data:`ERROR_STATUSES_PER_SECOND`)."""
        return self.limits.skip_error(time.monotonic())

    def garbage(self) -> int:
        """Count one piece of unparseable input; how many in the current second."""
        return self.limits.garbage(time.monotonic())

    def replies_full(self, calls: int = 0) -> bool:
        """Whether a new request must be refused: unread replies, and those of its ``calls``
        in flight, over ``--reply-buffer-limit``."""
        return replies_full(self.outbox, self.reply_limit, calls, self.reply_bytes)

    def _thinned(self, key: object) -> None:
        log.warning("slow link: %s thinned for client %s (%s): older messages dropped to keep "
                    "up with its other topics", key if key is not None else "topic data",
                    self.node, self.peer or "?")

    # ------------------------------------------------------------------ life
    def spawn(self, coro: Coroutine[Any, Any, Any]) -> asyncio.Task:
        """Run a coroutine tied to this client; it is cancelled when the client goes."""
        task = asyncio.ensure_future(coro)
        self.tasks.add(task)
        task.add_done_callback(self.tasks.discard)
        return task

    def close(self) -> bool:
        """The connection is gone: the client is closed and its queue freed now (not by the
        next full collection); False when it already was."""
        if self.closed:
            return False
        self.closed = True
        self.outbox.clear()
        return True

    def release(self, owner: object) -> None:
        """What the client gives back when its connection goes: its tasks, what ``owner``
        (its session) holds on the bus and its node; then its close callbacks run once (with
        ``owner``) and are dropped (they hold the server: no cycle outlives the session)."""
        for task in list(self.tasks):
            task.cancel()
        self.bus.remove_owner(owner)
        self.bus.unregister_node(self.node)
        for callback in self.on_close:
            callback(owner)
        self.on_close.clear()

"""The protections every client session shares, whatever its wire protocol (rosbridge,
Foxglove): how many reports of bad input and error statuses one client gets per second, so a
flood of junk or bogus ops cannot flood the client, the log or the server's memory; and the hard
bound on the replies a client leaves unread, past which it is disconnected; and what a client's
WebSocket control frames may cost (applied by the transport)."""

from __future__ import annotations

from collections.abc import Callable

from .outbox import Outbox

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

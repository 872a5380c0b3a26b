"""How many reports of bad input and error statuses one rosbridge client gets per second, so
a flood of junk or bogus ops cannot flood the client, the log or the server's memory."""

from __future__ import annotations

from ...protocol.errors import status_op
from ...wire.frames import json_frames
from ..outbox import Outbox

STREAM_ERRORS_PER_SECOND = 10
"""Most reports per second of unparseable TCP input that belongs to no op (garbage)."""

ERROR_STATUSES_PER_SECOND = 50
"""Most error statuses per second queued for a client that does not keep up with its replies
(:data:`BEHIND_BYTES` unread); the rest are counted and reported in one line, so a flood of
bogus ops cannot make the server hold a flood of errors."""
BEHIND_BYTES = 64 * 1024


class ReportLimits:
    """The per-second counts of one client's garbage reports and error statuses."""

    def __init__(self, outbox: Outbox):
        self.outbox = outbox
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
                self.outbox.put(json_frames(status_op(
                    "error", f"{self._errors_skipped} more error status(es) in the last second "
                    "not sent: this client does not read its replies fast enough")))
            self._errors_since, self._errors, self._errors_skipped = now, 0, 0
        self._errors += 1
        if self._errors <= ERROR_STATUSES_PER_SECOND or self.outbox.control_bytes < BEHIND_BYTES:
            return False
        self._errors_skipped += 1
        return True

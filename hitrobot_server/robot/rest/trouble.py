"""``Troubles``: the robot is reachable but its answers cannot be used.

A robot with a firmware bug or a half-broken link may keep answering HTTP 500, text that is not
JSON, shapes we cannot read or bodies over their bound (:mod:`.limits`). The link stays
connected (the robot does answer), so this is what tells ``/diagnostics_agg`` and ``/healthz``
why nothing useful comes: each read (``GET``) endpoint's latest bad answer, until that endpoint
answers well again or :data:`HOLD` seconds pass without another bad one.
"""

from __future__ import annotations

import time
from collections.abc import Callable

HOLD = 15.0
"""Seconds a bad answer is remembered when its endpoint is not read again."""
MOST = 32
"""Endpoints remembered at most (an action's own path has its id in it)."""


class Troubles:
    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self._clock = clock
        self._bad: dict[str, tuple[float, str]] = {}

    def bad(self, path: str, reason: str) -> None:
        self._bad.pop(path, None)
        self._bad[path] = (self._clock(), reason)
        while len(self._bad) > MOST:
            del self._bad[next(iter(self._bad))]

    def good(self, path: str) -> None:
        self._bad.pop(path, None)

    def clear(self) -> None:
        self._bad.clear()

    @property
    def reason(self) -> str:
        """The newest bad answer still held, and how many other endpoints answer badly; ""
        when every endpoint read lately answered well."""
        now = self._clock()
        for path in [p for p, (when, _) in self._bad.items() if now - when > HOLD]:
            del self._bad[path]
        if not self._bad:
            return ""
        newest = next(reversed(self._bad.values()))[1]
        others = len(self._bad) - 1
        return newest + (f" (and {others} other endpoint{'s' * (others > 1)})" if others else "")

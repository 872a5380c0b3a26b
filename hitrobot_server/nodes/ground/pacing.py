"""How often a poller behind some topics runs: at its own period while someone reads one of
them, at a tap's slower period when only a tap takes them (the black box), and at a slow
keep-alive otherwise (issue 50: nothing polled that nobody reads). A reader arriving wakes a
sleeping poller at once."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable, Hashable, Iterable
from typing import Protocol

KEEP_ALIVE = 2.0
"""Seconds between a poller's runs while nobody reads its topics: what a latched topic, the
map copy and a late subscriber's first message are at most that old."""


class Readers(Protocol):
    """What a poller asks of the bus (``bus.demand``: bus/demand.py)."""

    def period(self, name: str) -> float | None: ...

    def want(self, name: str, owner: Hashable) -> None: ...

    def unwant(self, name: str, owner: Hashable) -> None: ...

    def watch(self, names: Iterable[str], wake: Callable[[], None]) -> Callable[[], None]: ...


class Pace:
    """A poller's period, from who reads ``topics``; ``sleep`` ends early when that changes."""

    def __init__(self, readers: Readers, topics: Iterable[str], full: float,
                 idle: float = KEEP_ALIVE):
        self.readers, self.topics = readers, tuple(topics)
        self.full, self.idle = full, max(full, idle)
        self._sleeping: asyncio.Future[bool] | None = None
        self._unwatch = readers.watch(self.topics, self._wake)

    def follow(self, topics: Iterable[str]) -> None:
        """The poller publishes on other topics now (a name that follows the loaded map)."""
        self._unwatch()
        self.topics = tuple(topics)
        self._unwatch = self.readers.watch(self.topics, self._wake)
        self._wake()

    def unwatch(self) -> None:
        self._unwatch()

    def period(self) -> float:
        """The full period while any topic is read, a tap's slower one, else the keep-alive."""
        best: float | None = None
        for name in self.topics:
            wanted = self.readers.period(name)
            if wanted is not None and (best is None or wanted < best):
                best = wanted
        return self.idle if best is None else max(self.full, min(best, self.idle))

    async def sleep(self, delay: float) -> bool:
        """Sleep ``delay`` seconds; True when the readers changed meanwhile (run now)."""
        loop = asyncio.get_running_loop()
        future = self._sleeping = loop.create_future()
        timer = loop.call_later(delay, _settle, future, False)
        try:
            return await future
        finally:
            timer.cancel()
            self._sleeping = None

    def _wake(self) -> None:
        if self._sleeping is not None:
            _settle(self._sleeping, True)


def _settle(future: asyncio.Future[bool], value: bool) -> None:
    if not future.done():
        future.set_result(value)


async def repeat(period: float, work: Callable[[], Awaitable[None]], pace: Pace | None,
                 ready: Callable[[], bool]) -> None:
    """Run ``work`` every ``period`` (or as ``pace`` says) while ``ready()``, for ever, without
    drift or bursts; a reader arriving brings the next run forward, never closer than the
    full period to the last. ``work`` handles its own failures."""
    clock = asyncio.get_running_loop()
    due = clock.time()
    while True:
        began = clock.time()
        if ready():
            await work()
        due += pace.period() if pace is not None else period
        delay = due - clock.time()
        if delay < 0:
            due, delay = clock.time(), 0.0
        if pace is None:
            await asyncio.sleep(delay)
            continue
        while await pace.sleep(delay):  # the readers changed: look again
            due = max(began + pace.period(), clock.time())
            delay = due - clock.time()


"""Who reads a topic: what a poller behind its publisher asks before fetching at full rate.

A topic is read at its full rate while it has a subscriber here that asks for its data (a
client's, a node's that needs it), a subscriber in another process over the link, a node that
said it needs it (:meth:`Demand.want`), or a tap that keeps it whole (the recorder); at a tap's
own slower rate when only such a tap takes it (the black box); otherwise by nobody, and its
poller may keep it alive slowly. A node that listens without needing the data (the TF buffer,
the map manager's copy of the robot's map) subscribes with a :class:`Passive` key.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterable
from dataclasses import dataclass
from typing import Any, Protocol

from .link import RemoteGraph
from .names import canonical
from .topics import Topic

FULL = 0.0
"""A reader that takes every message: the publisher's own rate."""


@dataclass(frozen=True, slots=True)
class Passive:
    """A subscriber key that takes what is published but asks for nothing to be fetched."""

    key: Hashable


class Watched(Protocol):
    """What the demand reads of the bus (bus/core.py ``Bus``)."""

    topics: dict[str, Topic]
    taps: list[Any]

    def remote_graph(self) -> RemoteGraph: ...


class Demand:
    """Answers ``period(name)`` from the bus's subscribers, the link's and the taps'; tells
    the pollers watching a topic (``watch``) when its readers change."""

    def __init__(self, bus: Watched):
        self._topics, self._taps, self._remote_graph = bus.topics, bus.taps, bus.remote_graph
        self._remote: set[str] | None = None  # topics subscribed elsewhere, made on a miss
        self._wanted: dict[str, set[Hashable]] = {}
        self._watchers: dict[str, list[Callable[[], None]]] = {}

    def period(self, name: str) -> float | None:
        """``FULL`` when something reads ``name`` whole, a tap's slower period when only it
        does, None when nothing does."""
        name = canonical(name)
        topic = self._topics.get(name)
        if (topic is not None and any(not isinstance(k, Passive) for k in topic.subscribers)) \
                or self._wanted.get(name) or name in self._remote_topics():
            return FULL
        best: float | None = None
        for tap in self._taps:
            ask = getattr(tap, "demand", None)
            wanted = ask(name) if ask is not None else None
            if wanted is not None and (best is None or wanted < best):
                best = wanted
        return best

    def want(self, name: str, owner: Hashable) -> None:
        """``owner`` needs ``name`` at its full rate without subscribing to it."""
        name = canonical(name)
        self._wanted.setdefault(name, set()).add(owner)
        self._tell(name)

    def unwant(self, name: str, owner: Hashable) -> None:
        name = canonical(name)
        owners = self._wanted.get(name)
        if owners is not None and owner in owners:
            owners.discard(owner)
            if not owners:
                del self._wanted[name]
            self._tell(name)

    def watch(self, names: Iterable[str], wake: Callable[[], None]) -> Callable[[], None]:
        """Call ``wake`` whenever the readers of one of ``names`` may have changed; returns
        the function that stops it."""
        names = {canonical(n) for n in names}
        for name in names:
            self._watchers.setdefault(name, []).append(wake)

        def unwatch() -> None:
            for name in names:
                wakes = self._watchers.get(name, [])
                if wake in wakes:
                    wakes.remove(wake)
                if not wakes:
                    self._watchers.pop(name, None)

        return unwatch

    # ------------------------------------------------------------------ the bus tells (first)
    def changed(self, kind: str, name: str) -> None:
        """A local topic's publishers or subscribers changed."""
        if kind == "topic":
            self._tell(name)

    def remote_changed(self, kind: str, name: str) -> None:
        """Another process's graph changed (its subscribers among it)."""
        self._remote = None
        if kind == "topic":
            self._tell(name)

    def taps_changed(self) -> None:
        """A tap came or went (a recording started, the black box): every poller looks again."""
        for wakes in list(self._watchers.values()):
            for wake in list(wakes):
                wake()

    def _tell(self, name: str) -> None:
        for wake in list(self._watchers.get(canonical(name), ())):
            wake()

    def _remote_topics(self) -> set[str]:
        if self._remote is None:
            graph = self._remote_graph()
            self._remote = {t for t, nodes in graph.subscribers.items() if nodes}
        return self._remote


class ResolvedDemand:
    """The demand as a named robot's nodes see it: every name resolved into its namespace."""

    def __init__(self, demand: Demand, resolve: Callable[[str], str]):
        self._demand, self._resolve = demand, resolve

    def period(self, name: str) -> float | None:
        return self._demand.period(self._resolve(name))

    def want(self, name: str, owner: Hashable) -> None:
        self._demand.want(self._resolve(name), owner)

    def unwant(self, name: str, owner: Hashable) -> None:
        self._demand.unwant(self._resolve(name), owner)

    def watch(self, names: Iterable[str], wake: Callable[[], None]) -> Callable[[], None]:
        return self._demand.watch([self._resolve(n) for n in names], wake)

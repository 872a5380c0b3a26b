"""What the clients of one server were sent, per topic: counted where it happens, in plain
ints (a dict lookup and two additions per message and client), read by ``/metrics``.

The server hands one :class:`Traffic` to every session's outbox (``outbox.traffic``); the
outbox counts each topic message it takes for its client, and each it drops (thinned for a
slow client). What clients publish is counted on the bus (the metrics module's tap)."""

from __future__ import annotations

from collections.abc import Hashable


class Traffic:
    """Per topic: ``sent[topic] = [messages, bytes]`` and ``thinned[topic] = messages``."""

    __slots__ = ("sent", "thinned")

    def __init__(self) -> None:
        self.sent: dict[Hashable, list[int]] = {}
        self.thinned: dict[Hashable, int] = {}

    def count_sent(self, topic: Hashable, size: int) -> None:
        counts = self.sent.get(topic)
        if counts is None:
            counts = self.sent[topic] = [0, 0]
        counts[0] += 1
        counts[1] += size

    def count_thinned(self, topic: Hashable) -> None:
        self.thinned[topic] = self.thinned.get(topic, 0) + 1

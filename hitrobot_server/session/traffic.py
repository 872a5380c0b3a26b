"""What the clients of one server were sent, per topic: counted where it happens, in plain
ints (a dict lookup and two additions per message and client), read by ``/metrics``.

The server hands one :class:`Traffic` to every session's outbox (``outbox.traffic``); the
outbox counts each topic message it takes for its client, and each it drops (thinned for a
slow client). What clients publish is counted on the bus (the metrics module's tap)."""

from __future__ import annotations

from collections.abc import Hashable

MAX_TOPICS = 2000  # topics counted by name; topic names are the clients' to choose
OTHER_TOPICS = "(other topics)"  # where the messages of any further topic are counted


def counts_of(table: dict, topic: Hashable, zero, limit: int = MAX_TOPICS):
    """``table[topic]``, made ``zero()`` if new; past ``limit`` topics a new one is counted
    under :data:`OTHER_TOPICS`, so a server that sees ever new topic names (a client's
    per-session names, a hostile one's) keeps a bounded table for months."""
    if topic not in table and len(table) >= limit:
        topic = OTHER_TOPICS
    counts = table.get(topic)
    if counts is None:
        counts = table[topic] = zero()
    return counts


class Traffic:
    """Per topic: ``sent[topic] = [messages, bytes]`` and ``thinned[topic] = [messages]``,
    each for at most ``limit`` topics by name (the rest together)."""

    __slots__ = ("limit", "sent", "thinned")

    def __init__(self, limit: int = MAX_TOPICS) -> None:
        self.limit = limit
        self.sent: dict[Hashable, list[int]] = {}
        self.thinned: dict[Hashable, list[int]] = {}

    def count_sent(self, topic: Hashable, size: int) -> None:
        counts = self.sent.get(topic)
        if counts is None:
            counts = counts_of(self.sent, topic, _pair, self.limit)
        counts[0] += 1
        counts[1] += size

    def count_thinned(self, topic: Hashable) -> None:
        counts_of(self.thinned, topic, _one, self.limit)[0] += 1


def _pair() -> list[int]:
    return [0, 0]


def _one() -> list[int]:
    return [0]

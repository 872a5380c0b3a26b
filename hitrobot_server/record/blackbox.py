"""``--black-box SECONDS``: the last seconds of the recorded topics, kept in memory as CDR.

A bus tap like the recorder, but nothing leaves the process until a snapshot: each message is
kept as one tuple (its stamp, topic, sequence number and CDR) in a deque. The CDR is the one the
message already carries or makes once (``Message.cdr``: the Zenoh link and every Foxglove
client share it), so the loop pays one encoding per message and no copy. The oldest messages
go first, by age and by bytes (``--black-box-max-mb``), so the buffer never holds more than
its bound whatever the rate.
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass

from ..bus.cdr import codec_for
from ..bus.core import Bus
from ..bus.names import GlobFilter
from ..bus.tap import ClientOp
from ..bus.topics import Message, Topic
from .blackbox_file import Row

log = logging.getLogger(__name__)

PERIOD = 0.2
"""Seconds between the polls the black box alone asks for (pose, odometry, scans: 5 Hz); a
topic someone else reads comes at its full rate, and the box keeps all of it."""
ITEM_OVERHEAD = 160
"""What one kept message costs besides its CDR (the tuple, its float and int, the bytes
object's header), counted against the bound."""


@dataclass(frozen=True)
class Contents:
    """What the black box holds, for the snapshot reply and the bench."""

    messages: int
    bytes: int
    seconds: float


class BlackBox:
    """Keeps the last ``seconds`` of the topics ``topics`` allows, at most ``max_bytes``."""

    def __init__(self, bus: Bus, seconds: float, max_bytes: int, *, topics: str | None = None):
        self.bus = bus
        self.seconds = seconds
        self.max_bytes = max_bytes
        self.filter = GlobFilter.parse(topics)
        self.codec = codec_for(bus.types)
        self.bytes = 0
        self.failed = 0
        self._items: deque[tuple[float, Topic, int, bytes]] = deque()
        self._allowed: dict[str, bool] = {}

    def start(self) -> None:
        self.bus.taps.append(self)
        self.bus.demand.taps_changed()

    def stop(self) -> None:
        if self in self.bus.taps:
            self.bus.taps.remove(self)
            self.bus.demand.taps_changed()

    def demand(self, name: str) -> float | None:
        """The black box asks for its topics at :data:`PERIOD` at most: enough to see what
        the robot did before an incident, without polling it at full rate for nobody."""
        return PERIOD if self._allows(name) else None

    @property
    def contents(self) -> Contents:
        items = self._items
        span = items[-1][0] - items[0][0] if items else 0.0
        return Contents(len(items), self.bytes, span)

    # ------------------------------------------------------------------ loop side
    def message(self, message: Message) -> None:
        topic = message.topic
        if not self._allows(topic.name):
            return
        try:
            cdr = message.cdr(self.codec)
        except Exception as exc:  # a tap never raises into the bus
            self.failed += 1
            if self.failed == 1:
                log.warning("black box: %s cannot be encoded (%s); such messages are skipped",
                            topic.name, exc)
            return
        stamp = message.stamp
        items = self._items
        items.append((stamp, topic, message.seq, cdr))
        self.bytes += len(cdr) + ITEM_OVERHEAD
        oldest = stamp - self.seconds
        while items and (items[0][0] < oldest or self.bytes > self.max_bytes):
            self.bytes -= len(items.popleft()[3]) + ITEM_OVERHEAD

    def _allows(self, name: str) -> bool:
        allowed = self._allowed.get(name)
        if allowed is None:
            allowed = self._allowed[name] = self.filter.allows(name)
        return allowed

    def client_op(self, op: ClientOp) -> None:
        """Client ops go to a recording's audit channel; the black box keeps topics only."""

    # ------------------------------------------------------------------ snapshot
    def snapshot(self) -> list[Row]:
        """What the buffer holds now, opened by each latched topic's current message when it
        is older than the buffer (a replay then has the map)."""
        items = list(self._items)
        first = items[0][0] if items else self.bus.clock()
        kept = [_row(stamp, topic, seq, cdr, stamp) for stamp, topic, seq, cdr in items]
        opening = []
        for topic in list(self.bus.topics.values()):
            last = topic.last
            if (topic.latched and last is not None and last.stamp < first
                    and self._allows(topic.name)):
                try:
                    cdr = last.cdr(self.codec)
                except Exception:  # counted when it was published
                    continue
                opening.append(_row(first, topic, last.seq, cdr, last.stamp))
        return opening + kept


def _row(log_time: float, topic: Topic, seq: int, cdr: bytes, stamp: float) -> Row:
    return (topic.name, topic.type_name, topic.latched, int(log_time * 1e9), int(stamp * 1e9),
            seq, cdr)

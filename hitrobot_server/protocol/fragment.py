"""Fragmentation of outgoing JSON text and bounded reassembly of incoming ``fragment`` ops.

Outgoing fragments get non-empty string ids unique per message: rosbridge reuses the op's id
(``0`` for topic data, so messages collide and roslibjs 2.x drops fragments with a falsy id).
Incoming fragments are reassembled per client, joined by ``num`` (rosbridge joins in arrival
order), and held in bounded memory with a timeout so a client cannot grow the buffer forever.
"""

from __future__ import annotations

import itertools
from collections import OrderedDict
from dataclasses import dataclass, field

import orjson

from .errors import MessageId, ProtocolError, message_id

MIN_FRAGMENT_SIZE = 1024
"""Smallest ``fragment_size`` honoured: each fragment op costs ~70 bytes of framing and a Python
object, so ``fragment_size: 1`` turned a 365 kB map into 364,941 frames (+1.4 GB). Smaller
requests are raised to this, with a warning."""
MAX_FRAGMENTS = 10_000
"""Most fragments one message is cut into; a longer message gets longer fragments."""


def fragment_size_for(length: int, requested: int) -> int:
    """The piece size actually used for a ``length``-character text: the client's request,
    raised to :data:`MIN_FRAGMENT_SIZE` and to what keeps it within :data:`MAX_FRAGMENTS`."""
    return max(requested, MIN_FRAGMENT_SIZE, -(-length // MAX_FRAGMENTS))


def fragment(payload: str, size: int, msg_id: str) -> list[dict]:
    """Split the JSON text ``payload`` into ``fragment`` ops of at most ``size`` characters.

    ``num`` counts from 0 and ``total`` is an integer (rosbridge's is a float).
    """
    if size < 1:
        raise ValueError(f"fragment size must be at least 1, got {size}")
    chunks = [payload[start : start + size] for start in range(0, len(payload), size)] or [""]
    total = len(chunks)
    return [
        {"op": "fragment", "id": msg_id, "data": chunk, "num": num, "total": total}
        for num, chunk in enumerate(chunks)
    ]


def fragment_bytes(payload: str, size: int, msg_id: str) -> list[bytes]:
    """Like :func:`fragment`, but each op already encoded as a JSON frame (UTF-8 bytes)."""
    return [orjson.dumps(op) for op in fragment(payload, size, msg_id)]


class FragmentIds:
    """Ids for outgoing fragmented messages: ``fragment:<n>``, or ``fragment:<n>:<op id>``
    when the op has an id (kept for debugging; the counter alone makes ids unique)."""

    def __init__(self) -> None:
        self._counter = itertools.count(1)

    def next(self, op_id: MessageId = None) -> str:
        """A fresh id for the fragments of one message."""
        n = next(self._counter)
        return f"fragment:{n}" if op_id is None else f"fragment:{n}:{op_id}"


FRAGMENT_OVERHEAD = 64
"""Bytes charged per buffered fragment on top of its characters, approximating its bookkeeping
so that a flood of tiny fragments is bounded as well as a few huge ones."""


class FragmentBudget:
    """Bytes of fragment reassembly held by all clients together, against one limit, so many
    connections cannot each fill their own buffer."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.used = 0


@dataclass
class _Partial:
    total: int
    last: float
    cost: int = 0
    parts: dict[int, str] = field(default_factory=dict)


class Defragmenter:
    """Reassembles one client's incoming fragments.

    Bounds: ``max_bytes`` over all buffered messages (characters plus
    :data:`FRAGMENT_OVERHEAD` per fragment), the server-wide ``budget`` shared with every
    other client, ``max_messages`` messages in progress, and ``max_total`` fragments per
    message. A message that would exceed a bound is dropped with a :class:`ProtocolError`. A
    message with no new fragment for more than ``fragment_timeout`` seconds is evicted
    (:meth:`expire`, which the owner calls when :meth:`next_expiry` is due); a later fragment
    with its id starts a fresh message. :meth:`clear` frees everything when the client goes.
    """

    def __init__(
        self,
        *,
        max_bytes: int = 64 * 1024 * 1024,
        max_messages: int = 1000,
        max_total: int = 100_000,
        fragment_timeout: float = 600.0,
        budget: FragmentBudget | None = None,
    ) -> None:
        self.max_bytes = max_bytes
        self.budget = budget
        self.max_messages = max_messages
        self.max_total = max_total
        self.fragment_timeout = fragment_timeout
        self._partials: OrderedDict[str | int, _Partial] = OrderedDict()
        self._buffered = 0

    @property
    def pending(self) -> int:
        """Number of messages in progress."""
        return len(self._partials)

    @property
    def buffered(self) -> int:
        """Bytes currently charged against ``max_bytes``."""
        return self._buffered

    def next_expiry(self) -> float | None:
        """When the least recently fed message times out (None when nothing is pending)."""
        for partial in self._partials.values():
            return partial.last + self.fragment_timeout
        return None

    def clear(self) -> None:
        """Drop every message in progress and return its bytes to the budget."""
        for key in list(self._partials):
            self._drop(key)

    def expire(self, now: float) -> list[str | int]:
        """Evict messages with no new fragment for more than ``fragment_timeout`` seconds;
        returns their ids."""
        evicted = []
        # Ordered by last activity, oldest first, so the scan stops at the first fresh one.
        while self._partials:
            key, partial = next(iter(self._partials.items()))
            if now - partial.last <= self.fragment_timeout:
                break
            self._drop(key)
            evicted.append(key)
        return evicted

    def add(self, fragment: dict, now: float) -> str | None:
        """Store one ``fragment`` op; return the joined text once all its fragments are in.

        An invalid fragment raises :class:`ProtocolError` and is not stored; the rest of its
        message is kept unless a memory bound was exceeded.
        """
        self.expire(now)
        key, data, num, total = _checked(fragment)
        partial = self._partials.get(key)
        if total > self.max_total:
            self._drop(key)
            raise ProtocolError(
                f"fragment: field 'total' is {total}, more than the limit of {self.max_total} "
                "fragments per message",
                key,
            )
        if partial is None:
            if total == 1:
                return data
            if len(self._partials) >= self.max_messages:
                raise ProtocolError(
                    f"fragment: too many fragmented messages in progress (limit "
                    f"{self.max_messages}); message '{key}' was dropped",
                    key,
                )
            partial = self._partials[key] = _Partial(total, now)
        elif total != partial.total:
            raise ProtocolError(
                f"fragment: field 'total' is {total} but earlier fragments of message '{key}' "
                f"said {partial.total}",
                key,
            )
        elif num in partial.parts:
            raise ProtocolError(
                f"fragment: field 'num' {num} was already received for message '{key}'", key
            )
        cost = len(data) + FRAGMENT_OVERHEAD
        self._charge(key, cost)
        partial.parts[num] = data
        partial.cost += cost
        partial.last = now
        self._partials.move_to_end(key)
        if len(partial.parts) < partial.total:
            return None
        self._drop(key)
        return "".join(partial.parts[i] for i in range(partial.total))

    def _charge(self, key: str | int, cost: int) -> None:
        """Charge ``cost`` bytes of message ``key`` to this client's bound and the server's
        budget; over either, the message is dropped with a :class:`ProtocolError`."""
        if self._buffered + cost > self.max_bytes:
            self._drop(key)
            raise ProtocolError(
                f"fragment: message '{key}' exceeds the fragment buffer limit of "
                f"{self.max_bytes} bytes and was dropped",
                key,
            )
        budget = self.budget
        if budget is not None and budget.used + cost > budget.limit:
            self._drop(key)
            raise ProtocolError(
                f"fragment: message '{key}' was dropped: the server's fragment memory of "
                f"{budget.limit} bytes (all clients together) is full",
                key,
            )
        self._buffered += cost
        if budget is not None:
            budget.used += cost

    def _drop(self, key: str | int) -> None:
        partial = self._partials.pop(key, None)
        if partial is not None:
            self._buffered -= partial.cost
            if self.budget is not None:
                self.budget.used -= partial.cost


def _checked(op: dict) -> tuple[str | int, str, int, int]:
    """The id, data, num and total of a fragment op, each checked."""
    key = message_id(op)
    if key is None:
        raise ProtocolError("fragment: field 'id' is required and must be a string or an integer")
    data = op.get("data")
    if not isinstance(data, str):
        raise ProtocolError("fragment: field 'data' must be a string", key)
    num, total = op.get("num"), op.get("total")
    for name, value in (("num", num), ("total", total)):
        if not isinstance(value, int) or isinstance(value, bool):
            raise ProtocolError(f"fragment: field '{name}' must be an integer", key)
    if total < 1:
        raise ProtocolError(f"fragment: field 'total' must be 1 or greater, got {total}", key)
    if not 0 <= num < total:
        raise ProtocolError(
            f"fragment: field 'num' must be between 0 and total - 1 ({total - 1}), got {num}",
            key,
        )
    return key, data, num, total

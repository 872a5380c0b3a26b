"""A bus message's encodings, made once per key and shared by every reader.

A message fanned out to fifty clients is serialised once per encoding, not fifty times: the
main cost rosbridge pays per client (rosbridge #332, #559). Each encoding is named by a typed
:class:`MemoKey` that the protocol's own package declares (its name, its value type, how it is
made from the message); this module knows no protocol, so a new wire protocol adds keys of its
own and changes nothing here. The values live in the message's :class:`Memo`, which the bus
holds in ``Message.wire`` without looking; a publisher may hand one in already filled
(``Bus.publish``'s ``seed``: what it knows of the message, such as the client's own text).
A message's CDR is the bus's own (``Message.cdr``: its Zenoh link sends it).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any, Generic, TypeVar

import numpy as np

from ..bus.topics import Message

T = TypeVar("T")


class MemoKey(Generic[T]):
    """One kind of encoding of a message: a name (for a reader), and how it is made from the
    message and a variant (a topic spelling, a subscription id, ...) on first use; a key with
    no builder is only ever put by whoever knows its value (a publisher's own text)."""

    __slots__ = ("name", "build")

    def __init__(self, name: str, build: Callable[[Message, Any], T] | None = None) -> None:
        self.name = name
        self.build = build

    def __repr__(self) -> str:
        return f"MemoKey({self.name!r})"

    def get(self, message: Message, variant: Hashable = None) -> T:
        """This encoding of ``message`` in ``variant``, made on the first call, then shared."""
        memo = message.wire
        if memo is None:
            memo = message.wire = Memo()
        made = memo.made  # (one dict look-up on the fan-out path; the key's tuple hashes in C)
        found = made.get((self, variant))
        if found is None:
            if self.build is None:
                raise LookupError(f"{self!r} is only put, never built: peek it")
            found = made[(self, variant)] = self.build(message, variant)
        return found

    def peek(self, message: Message, variant: Hashable = None) -> T | None:
        """This encoding if someone already made it (or the publisher put it), else None."""
        memo = message.wire
        return None if memo is None else memo.made.get((self, variant))

    def put(self, message: Message, value: T, variant: Hashable = None) -> T:
        """Keep ``value`` as this encoding (one made by a caller that needs more than the
        message to make it: a server's frame builder)."""
        memo = message.wire
        if memo is None:
            memo = message.wire = Memo()
        memo.made[(self, variant)] = value
        return value


class Memo:
    """The encodings of one message made so far, by (key, variant), and an estimate of its
    size (as JSON): given by the publisher (the length of the op it came in) or estimated once
    (:func:`size_of`)."""

    __slots__ = ("made", "size")

    def __init__(self, size: int | None = None) -> None:
        self.made: dict[tuple[MemoKey[Any], Hashable], Any] = {}
        self.size = size

    def put(self, key: MemoKey[T], value: T, variant: Hashable = None) -> Memo:
        """What a publisher already has, before the message exists (chainable)."""
        self.made[(key, variant)] = value
        return self


PUBLISHED_JSON: MemoKey[bytes] = MemoKey("the publisher's own JSON")
"""The publisher's own text of the message: a JSON object whose ``msg`` member is the message
exactly as it is on the bus. Only ever put by a publisher that can vouch for it (a rosbridge
client's ``publish`` op the converter left as written); the recorder writes it as is."""


def size_of(message: Message) -> int:
    """Estimated JSON size of the message, computed once (or given by the publisher)."""
    memo = message.wire
    if memo is None:
        memo = message.wire = Memo()
    if memo.size is None:
        memo.size = approx_size(message.msg)
    return memo.size


def approx_size(value: object) -> int:
    """Rough JSON size of a canonical message, without encoding it (an over-estimate is fine:
    it only decides inline or offloaded, and what a queue is charged). Looks into dicts and the
    first item of a list; one call per nested dict, so a LaserScan costs three calls."""
    kind = type(value)
    if kind is dict:
        total = 16 * len(value)
        for item in value.values():
            kind = type(item)
            if kind is dict:
                total += approx_size(item)
            elif kind is list:
                total += _list_size(item)
            elif kind is bytes or kind is np.ndarray or kind is str:
                total += _flat_size(item)
            else:
                total += 12
        return total
    if kind is list:
        return _list_size(value)
    return _flat_size(value)


def _list_size(value: list) -> int:
    if not value:
        return 2
    first = type(value[0])
    each = approx_size(value[0]) if first is dict or first is list else 12
    return each * len(value)


def _flat_size(value: object) -> int:
    kind = type(value)
    if kind is bytes:
        return len(value) * 4 // 3
    if kind is np.ndarray:
        return value.size * (4 if value.itemsize == 1 else 24)
    if kind is str:
        return len(value) + 2
    return 12

"""What the wire floor knows of every message, whatever the protocol: its size, its
publisher's own text.

A message's encodings live in its memo (``bus/topics.py`` ``Memo``, by typed ``MemoKey``),
each key declared by the protocol's own package; this module adds the two that belong to no
protocol: the estimate of a message's size (queues are charged by it, big ones are encoded off
the loop) and :data:`PUBLISHED_JSON`, what a publisher can vouch for (the recorder peeks it).
"""

from __future__ import annotations

import numpy as np

from ..bus.topics import Memo, MemoKey, Message

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

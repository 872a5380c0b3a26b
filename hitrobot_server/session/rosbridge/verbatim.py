"""A client's own ``publish`` text as the outgoing op, when it can be vouched for."""

from __future__ import annotations

import orjson

from .encodings import publish_head, publish_json

VERBATIM_MIN = 2048
"""Publish ops shorter than this are re-encoded: checking the text costs about 2 us, encoding
a 2 kB message about as much, a 14 kB LaserScan 12 us."""


def verbatim_publish(text: str | bytes, op: dict) -> bytes | None:
    """The outgoing ``publish`` op cut from the client's own ``publish`` text, or None.

    Only for a message the converter left as it was (``from_json_verbatim``): then the text
    of its ``msg`` already is its JSON, and re-encoding it would be wasted work (a third of
    the cost of relaying a LaserScan). The keys around ``msg`` are re-serialised and must
    match the text exactly, so whatever sits between them is the ``msg`` value as parsed
    (with duplicate keys, a last-wins parser reads exactly what was validated); NaN/Infinity
    literals, which only the lenient fallback parser accepts, are never passed on.
    """
    data = text.encode() if type(text) is str else text
    keys = list(op)
    if keys == ["op", "topic", "msg"]:  # the op already is {"op":"publish","topic":T,"msg":…}
        head, tail = publish_head(op["topic"]), b"}"
    else:  # e.g. roslibjs: {"op","id","topic","msg","latch"}
        at = keys.index("msg")
        head = b"{" + b"".join(_member(k, op[k]) + b"," for k in keys[:at]) + b'"msg":'
        tail = b"".join(b"," + _member(k, op[k]) for k in keys[at + 1 :]) + b"}"
    if not (data.startswith(head) and data.endswith(tail)) or len(data) < len(head) + len(tail):
        return None
    if (b"N" in data and b"NaN" in data) or (b"I" in data and b"Infinity" in data):
        return None  # (one byte is a memchr; the 3-byte search costs 10 us on a LaserScan)
    if tail == b"}" and head == publish_head(op["topic"]):
        return data
    return publish_json(op["topic"], data[len(head) : len(data) - len(tail)])


def _member(key: str, value: object) -> bytes:
    return orjson.dumps(key) + b":" + orjson.dumps(value)

"""JSON text for the wire, with rosbridge's conventions for binary and non-finite values.

``bytes`` (canonical ``uint8[]``/``char[]``) become standard base64 strings, NaN/Inf become
``null`` (orjson's behaviour, and what rosbridge sends), numpy arrays and scalars are accepted.
"""

from __future__ import annotations

import base64
import json
import re
from typing import Any

import numpy as np
import orjson

_OPTIONS = orjson.OPT_SERIALIZE_NUMPY
_NON_ASCII = re.compile(r"[^\x00-\x7f]")


def _default(obj: Any) -> Any:
    if isinstance(obj, bytes | bytearray | memoryview):
        return base64.b64encode(obj).decode("ascii")
    if isinstance(obj, np.ndarray):
        # Non-contiguous or exotic-dtype arrays that orjson refuses natively.
        return obj.tolist()
    if isinstance(obj, np.floating):
        # longdouble: the one float width orjson's numpy support lacks.
        return float(obj)
    raise TypeError(f"Type is not JSON serializable: {type(obj).__name__}")


def dumps(obj: Any) -> bytes:
    """Serialise to compact UTF-8 JSON."""
    return orjson.dumps(obj, default=_default, option=_OPTIONS)


def _escape(match: re.Match[str]) -> str:
    code = ord(match.group())
    if code > 0xFFFF:
        code -= 0x10000
        return f"\\u{0xD800 + (code >> 10):04x}\\u{0xDC00 + (code & 0x3FF):04x}"
    return f"\\u{code:04x}"


def dumps_ascii(obj: Any) -> bytes:
    """Like :func:`dumps` but pure ASCII (``\\uXXXX``, surrogate pairs beyond the BMP).

    Needed for png-compressed payloads, which roslibjs 1.x turns back into text byte-by-byte
    as Latin-1, mangling any multi-byte UTF-8 sequence.
    """
    data = dumps(obj)
    if data.isascii():
        return data
    # orjson only emits non-ASCII inside string literals, so escaping them in place is safe.
    return _NON_ASCII.sub(_escape, data.decode("utf-8")).encode("ascii")


def loads(data: bytes | bytearray | memoryview | str) -> Any:
    """Parse JSON text; raises ``orjson.JSONDecodeError`` (a ``ValueError``) when malformed.

    Python's ``json.dumps`` (so roslibpy) writes ``NaN``/``Infinity`` literals, which
    rosbridge accepts but strict JSON and orjson do not; only when orjson refuses is the
    text re-read by the standard library, so the fast path stays fast.
    """
    try:
        return orjson.loads(data)
    except orjson.JSONDecodeError as exc:
        text = bytes(data) if isinstance(data, memoryview | bytearray) else data
        literals = (b"NaN", b"Infinity") if isinstance(text, bytes) else ("NaN", "Infinity")
        if not any(lit in text for lit in literals):
            raise  # no NaN/Infinity literal could be the reason
        try:
            return json.loads(text)
        except ValueError:
            raise exc from None

"""JSON text for the wire, with rosbridge's conventions for binary and non-finite values.

``bytes`` (canonical ``uint8[]``/``char[]``) become standard base64 strings, NaN/Inf become
``null`` (orjson's behaviour, and what rosbridge sends), numpy arrays and scalars are accepted.

Every decoded value (JSON here, CBOR in :mod:`hitrobot_server.protocol.cbor`) passes
:func:`check_value` unless orjson produced it: a string that is not valid Unicode (a lone
surrogate), an integer wider than 64 bits or a container nested too deep would otherwise be
stored and then fail every later attempt to send it, to anyone.
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


SNUG_BELOW = 64 * 1024
"""orjson's output keeps a buffer about 4 KiB larger than its text (measured on 3.13: a 114-byte
status holds 4.1 KiB of RSS), so 100,000 queued statuses would hold 400 MiB; an output shorter
than this is copied into a snug one (0.1-0.7 us), a longer one wastes under 6 %."""


def dumps(obj: Any) -> bytes:
    """Serialise to compact UTF-8 JSON."""
    data = orjson.dumps(obj, default=_default, option=_OPTIONS)
    return bytes(memoryview(data)) if len(data) < SNUG_BELOW else data


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


MAX_DEPTH = 1000
"""Deepest nesting of arrays and objects accepted (orjson's own limit is 1024)."""
_INT_MIN, _INT_MAX = -(2**63), 2**64 - 1  # int64 to uint64: the widest ROS integers


class InvalidValue(ValueError):
    """A decoded value the server cannot carry; the text names where, never the value.

    ``id`` is the top-level object's ``id`` when that one is valid, so the error can be
    reported against the op it belongs to.
    """

    def __init__(self, text: str, id: str | int | None = None) -> None:
        super().__init__(text)
        self.id = id


def top_id(obj: Any) -> str | int | None:
    """The top-level object's ``id`` when it is a valid one (to report an error against its op)."""
    if isinstance(obj, dict):
        value = obj.get("id")
        if (type(value) is str and _utf8(value)) or (
            type(value) is int and _INT_MIN <= value <= _INT_MAX
        ):
            return value
    return None


def _utf8(text: str) -> bool:
    if text.isascii():
        return True
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _field(path: str) -> str:
    return f"field '{path}'" if path else "the message"


def _bad_scalar(value: Any, path: str, allow_bytes: bool) -> str | None:
    """Why a non-container value cannot be carried, or None when it can."""
    kind = type(value)
    if kind is str:
        return None if _utf8(value) else f"{_field(path)} is not valid Unicode (lone surrogate)"
    if kind is int:
        if _INT_MIN <= value <= _INT_MAX:
            return None
        return f"{_field(path)} is an integer outside the 64-bit range"
    if kind is float or kind is bool or value is None:
        return None
    if allow_bytes and (kind is bytes or kind is np.ndarray):  # CBOR: byte and typed arrays
        return None
    return f"{_field(path)} has an unsupported type ({kind.__name__})"


def check_value(obj: Any, *, allow_bytes: bool = False, max_depth: int = MAX_DEPTH) -> None:
    """Raise :class:`InvalidValue` unless ``obj`` holds only JSON values the server can encode
    again: UTF-8-encodable strings (keys too), integers within int64..uint64, floats (NaN and
    infinities included), booleans, null, lists and string-keyed objects (and ``bytes`` and
    numpy typed arrays when ``allow_bytes``, for CBOR), nested at most ``max_depth`` deep.
    Iterative, so depth cannot exhaust the stack.
    """
    problem = _problem(obj, allow_bytes, max_depth)
    if problem is not None:
        raise InvalidValue(problem, top_id(obj))


def _problem(obj: Any, allow_bytes: bool, max_depth: int) -> str | None:
    stack: list[tuple[Any, str, int]] = [(obj, "", 0)]
    while stack:
        value, path, depth = stack.pop()
        kind = type(value)
        if kind is dict:
            if depth >= max_depth:
                return f"{_field(path)} is nested deeper than {max_depth} levels"
            prefix = f"{path}." if path else ""
            for key, item in value.items():
                if type(key) is not str or not _utf8(key):
                    return f"{_field(path)} has a key that is not a valid Unicode string"
                if type(item) is dict or type(item) is list:
                    stack.append((item, prefix + key, depth + 1))
                elif (problem := _bad_scalar(item, prefix + key, allow_bytes)) is not None:
                    return problem
        elif kind is list:
            if depth >= max_depth:
                return f"{_field(path)} is nested deeper than {max_depth} levels"
            for i, item in enumerate(value):
                if type(item) is dict or type(item) is list:
                    stack.append((item, f"{path}[{i}]", depth + 1))
                elif type(item) is not float and (
                    problem := _bad_scalar(item, f"{path}[{i}]", allow_bytes)
                ) is not None:
                    return problem
        elif (problem := _bad_scalar(value, path, allow_bytes)) is not None:
            return problem
    return None


def loads(data: bytes | bytearray | memoryview | str) -> Any:
    """Parse JSON text; raises a ``ValueError`` (``orjson.JSONDecodeError`` when malformed,
    :class:`InvalidValue` when it holds a value the server cannot carry).

    Python's ``json.dumps`` (so roslibpy) writes ``NaN``/``Infinity`` literals, which
    rosbridge accepts but strict JSON and orjson do not; only when orjson refuses is the
    text re-read by the standard library, so the fast path stays fast. That parser also
    accepts lone surrogates, integers of any size and unbounded nesting, so what it returns
    goes through :func:`check_value` (orjson refuses all three itself, and reads integers
    beyond 64 bits as floats).
    """
    try:
        return orjson.loads(data)
    except orjson.JSONDecodeError as exc:
        text = bytes(data) if isinstance(data, memoryview | bytearray) else data
        literals = (b"NaN", b"Infinity") if isinstance(text, bytes) else ("NaN", "Infinity")
        if not any(lit in text for lit in literals):
            raise  # no NaN/Infinity literal could be the reason
        try:
            obj = json.loads(text)
        except (ValueError, RecursionError):
            raise exc from None
    check_value(obj)
    return obj

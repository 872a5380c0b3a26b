"""Whole-op codecs shared by the inline path and the worker process that runs big messages.

Measured on CPython 3.11 (bench/README.md): ``orjson.loads``/``dumps``, ``cbor2`` and numpy's
conversion of Python lists hold the GIL for the whole call, so a 10 MB map parsed or encoded in a
*thread* still stalls the event loop for the whole call (100-150 ms); zlib releases it, PIL's PNG
encode only partly (25 ms stalls). Big ops therefore go to a worker *process*. What crosses the
process boundary is pickled, so long numeric lists are turned into compact numpy arrays before
they go back: a 4M-cell map is 4 MB of int8, not 4M Python ints. The same functions build the
inline encodings, so an offloaded message is byte-for-byte what the inline path sends.
"""

from __future__ import annotations

import functools

import numpy as np
import orjson

from ..types import jsoncodec
from . import cbor, png
from .fragment import fragment_bytes, fragment_size_for

Frame = tuple[bytes, bool]  # (payload, is_binary)

OFFLOAD_BYTES = 256 * 1024
"""Ops and messages at least this big (JSON bytes, or an estimate) leave the event loop. Inline,
256 kB cost about 5 ms to parse, convert and encode, a pool round trip about 1 ms."""

COMPACT_MIN = 1024
"""Lists shorter than this are cheap to pickle as they are."""

_INT_DTYPES = (np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32, np.int64)
_CONTAINERS = (dict, list)


class DecodeError(ValueError):
    """A frame that is not valid JSON/CBOR; the text is what the inline parser says, ``id``
    the op's id when the parser could tell it."""

    def __init__(self, text: str, id: object = None) -> None:
        super().__init__(text)
        self.id = id

    def __reduce__(self):  # pickled back from the worker with its id
        return (DecodeError, (str(self), self.id))


class PngError(ValueError):
    """A ``png`` op whose ``data`` is not a PNG holding text."""


# ------------------------------------------------------------------------ incoming
def _int_array(value: list) -> np.ndarray | list:
    try:
        wide = np.array(value, dtype=np.int64)
    except OverflowError:  # beyond int64 (a uint64 field): keep the exact Python ints
        return value
    lo, hi = wide.min(), wide.max()
    for dtype in _INT_DTYPES:
        info = np.iinfo(dtype)
        if info.min <= lo and hi <= info.max:
            return wide.astype(dtype)
    return wide


def compact_arrays(value: object) -> object:
    """Lists of at least ``COMPACT_MIN`` plain ints (or plain floats) become the smallest numpy
    array holding them, at any depth. Anything else (bools, nulls, strings, mixed) is left as
    it is, so the converter still sees, and names, every value it would refuse."""
    kind = type(value)
    if kind is dict:
        for key, item in value.items():
            if type(item) in _CONTAINERS:
                value[key] = compact_arrays(item)
    elif kind is list:
        kinds = set(map(type, value))
        if len(value) >= COMPACT_MIN and len(kinds) == 1:
            if int in kinds:
                return _int_array(value)
            if float in kinds:
                return np.array(value, dtype=np.float64)
        if kinds & {dict, list}:
            for i, item in enumerate(value):
                if type(item) in _CONTAINERS:
                    value[i] = compact_arrays(item)
    return value


def decode_json(data: str | bytes) -> object:
    """Parse one JSON text op for the worker; raises :class:`DecodeError` (picklable, short)."""
    try:
        obj = jsoncodec.loads(data)
    except ValueError as exc:
        raise DecodeError(str(exc), getattr(exc, "id", None)) from None
    return compact_arrays(obj)


def decode_cbor(data: bytes) -> object:
    try:
        obj = cbor.decode(data)
    except Exception as exc:  # cbor2.CBORDecodeError, jsoncodec.InvalidValue
        raise DecodeError(str(exc), getattr(exc, "id", None)) from None
    return compact_arrays(obj)


def decode_png(b64: str, max_bytes: int | None = None) -> object:
    """The op held by a ``png`` op's ``data``; an image declaring more than ``max_bytes`` of
    pixels is refused before it is decoded (a png bomb)."""
    try:
        text = png.decode(b64, max_bytes)
    except Exception as exc:
        raise PngError(str(exc)) from None
    return decode_json(text)


# ------------------------------------------------------------------------ outgoing
@functools.lru_cache(maxsize=1024)
def _publish_head(topic: str) -> bytes:
    return b'{"op":"publish","topic":' + orjson.dumps(topic) + b',"msg":'


def publish_json(topic: str, msg_json: bytes) -> bytes:
    """``{"op":"publish","topic":T,"msg":…}`` around an already serialised body."""
    return b"".join((_publish_head(topic), msg_json, b"}"))


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
        head, tail = _publish_head(op["topic"]), b"}"
    else:  # e.g. roslibjs: {"op","id","topic","msg","latch"}
        at = keys.index("msg")
        head = b"{" + b"".join(_member(k, op[k]) + b"," for k in keys[:at]) + b'"msg":'
        tail = b"".join(b"," + _member(k, op[k]) for k in keys[at + 1 :]) + b"}"
    if not (data.startswith(head) and data.endswith(tail)) or len(data) < len(head) + len(tail):
        return None
    if (b"N" in data and b"NaN" in data) or (b"I" in data and b"Infinity" in data):
        return None  # (one byte is a memchr; the 3-byte search costs 10 us on a LaserScan)
    if tail == b"}" and head == _publish_head(op["topic"]):
        return data
    return publish_json(op["topic"], data[len(head) : len(data) - len(tail)])


def _member(key: str, value: object) -> bytes:
    return orjson.dumps(key) + b":" + orjson.dumps(value)


def publish_png(topic: str, msg: dict, op_json: bytes) -> bytes:
    """The ``png`` op of a publish whose JSON text is ``op_json``."""
    if not op_json.isascii():  # roslibjs 1.x decodes png pixels as Latin-1
        op_json = jsoncodec.dumps_ascii({"op": "publish", "topic": topic, "msg": msg})
    return png.png_op(op_json)


def fragments(data: bytes, size: int, frag_id: str) -> list[Frame]:
    """Encoded JSON split into ``fragment`` ops with the id ``frag_id``, in pieces of ``size``
    characters or as many more as the bounds of :func:`~.fragment.fragment_size_for` need."""
    text = data.decode()
    size = fragment_size_for(len(text), size)
    return [(frame, False) for frame in fragment_bytes(text, size, frag_id)]


def reply_data(obj: dict, compression: str = "none") -> bytes:
    """A reply op (service_response, action_result, status, ...) as one JSON or png frame."""
    data = jsoncodec.dumps(obj)
    if compression == "png":
        if not data.isascii():
            data = jsoncodec.dumps_ascii(obj)
        data = png.png_op(data)
    return data


def reply_frames(obj: dict, fragment_size: int | None, compression: str,
                 frag_id: str) -> list[Frame]:
    """Every frame of one reply op; what the worker builds for a big one."""
    data = reply_data(obj, compression)
    if fragment_size and len(data) > fragment_size:
        return fragments(data, fragment_size, frag_id)
    return [(data, False)]


def publish_frames(
    topic: str, msg: dict, compression: str, fragment_size: int | None, frag_id: str
) -> list[Frame]:
    """Every frame one text subscriber (``none`` or ``png``) gets for one message."""
    data = publish_json(topic, jsoncodec.dumps(msg))
    if compression == "png":
        data = publish_png(topic, msg, data)
    if fragment_size and len(data) > fragment_size:
        return fragments(data, fragment_size, frag_id)
    return [(data, False)]


# ------------------------------------------------------------------------ sizes
def approx_size(value: object) -> int:
    """Rough JSON size of a canonical message, without encoding it (an over-estimate is fine:
    it only decides inline or offloaded). Looks into dicts and the first item of a list; one
    call per nested dict, so a LaserScan costs three calls."""
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

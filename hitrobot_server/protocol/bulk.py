"""Whole-op codecs shared by the inline path and the worker process that runs big messages.

Measured on CPython 3.11 (bench/README.md): ``orjson.loads``/``dumps``, ``cbor2`` and numpy's
conversion of Python lists hold the GIL for the whole call, so a 10 MB map parsed or encoded in a
*thread* still stalls the event loop for the whole call (100-150 ms); zlib releases it, PIL's PNG
encode only partly (25 ms stalls). Big ops therefore go to a worker *process*. What crosses the
process boundary is pickled, so long numeric lists are turned into compact numpy arrays before
they go back: a 4M-cell map is 4 MB of int8, not 4M Python ints. The same functions build the
inline encodings, so an offloaded reply is byte-for-byte what the inline path sends (a bus
message's publish ops are built the same way by bus/encoded.py).
"""

from __future__ import annotations

import numpy as np

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

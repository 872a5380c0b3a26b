"""Incoming whole-op decoders shared by the inline path and the worker process that runs big ops.

Measured on CPython 3.11 (bench/README.md): ``orjson.loads``/``dumps``, ``cbor2`` and numpy's
conversion of Python lists hold the GIL for the whole call, so a 10 MB map parsed or encoded in a
*thread* still stalls the event loop for the whole call (100-150 ms); zlib releases it, PIL's PNG
encode only partly (25 ms stalls). Big ops therefore go to a worker *process*. What crosses the
process boundary is pickled, so long numeric lists are turned into compact numpy arrays before
they go back: a 4M-cell map is 4 MB of int8, not 4M Python ints. Outgoing ops (published
messages and replies) are built by rosbridge's frame builder
(hitrobot_server/session/rosbridge/frames.py), the same way inline and in the worker.
"""

from __future__ import annotations

import numpy as np

from ..types import jsoncodec
from . import cbor, png

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

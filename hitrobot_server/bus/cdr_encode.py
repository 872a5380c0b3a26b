"""ROS 2 CDR written straight from a canonical (ROS 1 shaped) message, without rosbags objects.

:class:`~hitrobot_server.bus.cdr.Ros2Codec` first made a rosbags object of every message and
had rosbags serialise it: for a 720-range LaserScan that is a dataclass per nested message, a
``numpy.asarray`` per float list and rosbags' size pass, about 40 µs, paid by the recorder's
writer for every client publish. Here each type gets, once, a plan of small writers that append
to one ``bytearray``: scalars with ``struct``, a list of numbers with one ``struct.pack``,
numpy arrays and bytes by their buffer. The bytes are rosbags' own (tests/bus/test_cdr_fast.py
compares them type by type): the same field conversions as the codec's rosbags path (a missing
field or a ``None`` scalar is zero, a time is ``secs``/``nsecs`` or ``sec``/``nanosec``), the
same ``struct`` codes as rosbags' primitives, and every value padded to its own size from the
start of the body, which is where rosbags' generated code pads. Anything this plan does not
convert exactly as the reference does makes it raise, and the codec then takes the rosbags path,
so a bad message still fails with the reference's error.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype

from ..types.registry import NUMPY_DTYPES

HEADER = b"\x00\x01\x00\x00"  # CDR little-endian encapsulation
MISSING = object()
TIMES = frozenset({"builtin_interfaces/msg/Time", "builtin_interfaces/msg/Duration"})
ZERO = {"string": "", "bool": False, "float32": 0.0, "float64": 0.0}
# rosbags.serde.primitives' codes (``byte`` is signed there, ``char`` unsigned)
CODES = {"bool": "?", "byte": "b", "char": "B", "int8": "b", "uint8": "B", "int16": "h",
         "uint16": "H", "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q",
         "float32": "f", "float64": "d"}
# numbers a list packs with one struct call exactly as numpy.asarray converts them (bool is
# left to numpy: struct's "?" takes any object's truth, numpy does not)
LIST_CODES = {t: c for t, c in CODES.items() if t != "bool"}
_PADS = tuple(bytes(n) for n in range(8))
_LENGTH = struct.Struct("<i")
_TIME = struct.Struct("<iI")

Write = Callable[[bytearray, Any], None]
Encode = Callable[[Any], bytes]


class Unsupported(Exception):
    """A field this plan does not write (wstring, float128): the type takes the rosbags path."""


def _pad(out: bytearray, align: int) -> None:
    pad = (4 - len(out)) % align  # from the start of the body, after the 4-byte header
    if pad:
        out += _PADS[pad]


def _string(out: bytearray, v: Any) -> None:
    raw = v.encode()
    _pad(out, 4)
    out += _LENGTH.pack(len(raw) + 1)
    out += raw
    out += b"\0"


class DirectEncoder:
    """Compiled CDR writers of the types of one rosbags store (the codec's ROS 2 store)."""

    def __init__(self, fielddefs: Callable[[str], list[tuple[str, Any]]]):
        self._fields = fielddefs  # a type's (name, desc) fields, made known to the store
        self._writers: dict[str, Write] = {}
        self._flat: dict[str, bool] = {}

    def encoder(self, name: str) -> Encode | None:
        """The CDR encoder of type ``name``, or None when it holds a field not written here."""
        try:
            write = self._message(name)
        except Unsupported:
            return None

        def encode(msg: Any) -> bytes:
            out = bytearray(HEADER)
            write(out, msg)
            return bytes(out)

        return encode

    def flat(self, name: str) -> bool:
        """Written here with no message per array element (a Path's poses, a MarkerArray's
        markers): its CDR then costs about what copying its arrays does, whatever its size."""
        found = self._flat.get(name)
        if found is None:
            found = self._flat[name] = all(self._flat_field(d) for _n, d in self._fields(name))
        return found

    def _flat_field(self, desc: Any) -> bool:
        if desc[0] == Nodetype.NAME:
            return desc[1] in TIMES or self.flat(desc[1])
        if desc[0] == Nodetype.BASE:
            return desc[1][0] == "string" or desc[1][0] in CODES
        elem = desc[1][0]
        return elem[0] == Nodetype.BASE and (elem[1][0] == "string" or elem[1][0] in CODES)

    def _message(self, name: str) -> Write:
        write = self._writers.get(name)
        if write is not None:
            return write
        plan: list[tuple[str | None, Any]] = []  # (field, writer) or (None, a run's writer)
        run: list[tuple[str, str]] = []  # consecutive number fields: one struct call
        for fname, desc in self._fields(name):
            if desc[0] == Nodetype.BASE and desc[1][0] in CODES:
                run.append((fname, desc[1][0]))
                continue
            if run:
                plan.append((None, _numbers_run(run)))
                run = []
            plan.append((fname, self._field(desc)))
        if run:
            plan.append((None, _numbers_run(run)))

        def write(out: bytearray, msg: Any) -> None:
            if not isinstance(msg, dict):
                msg = {}
            get = msg.get
            for fname, field in plan:
                if fname is None:
                    field(out, get)
                else:
                    field(out, get(fname, MISSING))

        self._writers[name] = write
        return write

    def _field(self, desc: Any) -> Write:
        kind = desc[0]
        if kind == Nodetype.NAME:
            return self._name(desc[1])
        if kind == Nodetype.BASE:  # numbers are written in runs (_numbers_run)
            if desc[1][0] != "string":
                raise Unsupported(desc[1][0])
            return _scalar_string
        elem, length = desc[1]
        fixed = length if kind == Nodetype.ARRAY else None
        if elem[0] == Nodetype.BASE:
            typ = elem[1][0]
            if typ == "string":
                return _each(_string, fixed, "")
            if typ not in CODES:
                raise Unsupported(typ)
            return _numbers(typ, fixed)
        return _each(self._field(elem), fixed, MISSING)

    def _name(self, sub: str) -> Write:
        if sub in TIMES:
            return _time
        inner = self._message(sub)

        def nested(out: bytearray, v: Any) -> None:
            inner(out, {} if v is MISSING else v)

        return nested


def _time(out: bytearray, v: Any) -> None:
    if v is MISSING:
        sec = nanosec = 0
    else:
        sec = int(v.get("secs", v.get("sec", 0)))
        nanosec = int(v.get("nsecs", v.get("nanosec", 0)))
    _pad(out, 4)
    out += _TIME.pack(sec, nanosec)


def _scalar_string(out: bytearray, v: Any) -> None:
    _string(out, "" if v is MISSING or v is None else v)


def _numbers_run(fields: list[tuple[str, str]]) -> Callable[[bytearray, Any], None]:
    """Consecutive number fields in one ``struct`` call: a format per place of the run's
    start in an 8-byte word, each value padded to its size as it would be alone."""
    formats = []
    for start in range(8):
        pos, fmt = start, "<"
        for _fname, typ in fields:
            size = struct.calcsize(CODES[typ])
            pad = -pos % size
            fmt += "x" * pad + CODES[typ]
            pos += pad + size
        formats.append(struct.Struct(fmt).pack)
    names = [(fname, ZERO.get(typ, 0)) for fname, typ in fields]

    def numbers_run(out: bytearray, get: Any) -> None:
        values = []
        for fname, zero in names:
            v = get(fname, MISSING)
            values.append(zero if v is MISSING or v is None else v)
        out += formats[(len(out) - 4) % 8](*values)

    return numbers_run


def _count(out: bytearray, count: int, fixed: int | None) -> None:
    """A sequence's element count (uint32); a fixed array's length is checked instead."""
    if fixed is None:
        _pad(out, 4)
        out += _LENGTH.pack(count)
    elif count != fixed:
        raise ValueError("unexpected array length")


def _each(one: Write, fixed: int | None, missing: Any) -> Write:
    """An array or sequence of strings or messages, element by element (``missing``: a
    missing array's elements)."""

    def each(out: bytearray, v: Any) -> None:
        values = [missing] * (fixed or 0) if v is MISSING else list(v)
        _count(out, len(values), fixed)
        for item in values:
            one(out, item)

    return each


def _numbers(typ: str, fixed: int | None) -> Write:
    dtype = NUMPY_DTYPES[typ]
    size = np.dtype(dtype).itemsize
    code = LIST_CODES.get(typ)

    def data_of(v: Any) -> Any:
        """The elements' bytes, converted as the codec's rosbags path converts them."""
        if v is MISSING:
            return bytes(size * (fixed or 0))
        if code is not None and v.__class__ is list:
            try:
                return struct.pack(f"<{len(v)}{code}", *v)
            except (struct.error, TypeError, ValueError, OverflowError):
                pass  # None (NaN in a float array), strings, ...: numpy's conversion
        if isinstance(v, bytes | bytearray | memoryview):
            arr = np.frombuffer(v, dtype=dtype)
        else:
            arr = np.asarray(v, dtype=dtype)
        if arr.ndim != 1:
            raise ValueError("not a one-dimensional array")
        return arr.view(np.uint8).data  # raises for a strided array, as rosbags' write does

    def numbers(out: bytearray, v: Any) -> None:
        data = data_of(v)
        count = len(data) // size
        _count(out, count, fixed)
        if count and size > 1:
            _pad(out, size)
        out += data

    return numbers

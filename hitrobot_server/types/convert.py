"""JSON-decoded values → canonical in-process messages, validated against the message type.

The canonical message is a fully populated dict keyed by field name: base values are
int/float/str/bool, ``uint8``/``char`` arrays are ``bytes``, ``time``/``duration`` are
``{"secs", "nsecs"}`` with ``0 <= nsecs < 1e9``, other arrays are lists, nested messages dicts.

Rules (rosbridge's ROS 1 conventions plus the choices below):

* A JSON integer is accepted for a float field. A float is accepted for an integer field only when
  it is integral (``3.0`` → ``3``): JavaScript cannot tell the two apart. ``bool`` is never a
  number. Integers are range-checked for the field's width.
* ``null`` in a float field (scalar or array element) means NaN: rosbridge sends NaN/Inf as
  ``null`` and clients echo them back.
* ``uint8``/``char`` arrays take standard base64 text, a list of integers 0-255, or bytes (CBOR).
* ``time``/``duration`` take ``{secs,nsecs}``, ``{sec,nanosec}``, ``{sec,nsec}``, a number of
  seconds, or (``time`` only) the string ``"now"``.
* Omitted fields get defaults and their paths are reported so the caller can warn.
* Integer arrays of ``BIG_ARRAY`` or more elements (other than uint64) become numpy arrays of
  the field's width; smaller arrays stay lists. Encoders accept both.
* Numeric arrays may also arrive as numpy arrays (big ops are parsed in a worker process, which
  compacts long lists, see protocol/bulk.py). They are checked with numpy and give the same
  result as the list would; a float array of ``BIG_ARRAY`` or more stays a float64 numpy array.
  Any value numpy cannot vouch for goes through the list path, so errors read the same.
* Header auto-fill, applied to every ``std_msgs/Header`` value at any depth: an omitted ``stamp``
  becomes now, an omitted header becomes ``{seq: 0, stamp: now, frame_id: ""}``. Neither is
  reported as missing, nor is an omitted ``seq`` (publishers number messages themselves).
* Any other omitted ``time`` field named ``stamp`` (``actionlib_msgs/GoalID.stamp``: roslibjs 1.x
  cancels with ``{id}`` only) gets the default 0 and is not reported either: filling a stamp
  is what clients expect, not a mistake to warn about.
* An omitted optional value (a Slamware ``Optional*`` field: ``is_valid`` + ``value``) is "not
  given" (``is_valid`` false) and is not reported either.

Converters are compiled once per type and cached on the registry, so steady-state cost is one
closure call per field plus C-level type checks for numeric arrays.
"""

from __future__ import annotations

import base64
import binascii
import math
import time
from collections.abc import Callable
from operator import countOf
from typing import Any

import numpy as np

from hitrobot_server.types.aliases import FIELD_ALIASES, SIGNED_BYTES
from hitrobot_server.types.registry import HEADER, Field, MsgType, TypeRegistry

NowFn = Callable[[], tuple[int, int]]

_NAN = math.nan
_NSEC = 1_000_000_000
_MISSING = object()
_INT_RANGES = {
    "int8": (-(2**7), 2**7 - 1),
    "byte": (-(2**7), 2**7 - 1),
    "uint8": (0, 2**8 - 1),
    "char": (0, 2**8 - 1),
    "int16": (-(2**15), 2**15 - 1),
    "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1),
    "uint64": (0, 2**64 - 1),
}
_FLOATS = frozenset({"float32", "float64"})
_BYTE_ARRAYS = frozenset({"uint8", "char"})
_JSON_NAMES = {
    bool: "boolean",
    int: "integer",
    float: "number",
    str: "string",
    list: "array",
    tuple: "array",
    dict: "object",
    np.ndarray: "array",
    type(None): "null",
    bytes: "bytes",
}
_ONLY_INT = frozenset({int})
_FLOAT_LIKE = frozenset({float, int, type(None)})
# rosbags serialises ROS 1 time/duration as int32 seconds, so that is the range we can carry.
_SECS_RANGE = {"time": (0, 2**31 - 1), "duration": (-(2**31), 2**31 - 1)}
_TIME_EXPECTED = {
    "time": 'a time ({secs, nsecs}, seconds or "now")',
    "duration": "a duration ({secs, nsecs} or seconds)",
}


class ConversionError(ValueError):
    """A value does not fit its message type; the text names the offending field path."""


class _Ctx:
    """Per-call state: the missing-field list, a lazily read, call-wide 'now', and whether any
    value had to be changed (filled, retyped, renamed) on its way to the canonical message."""

    __slots__ = ("missing", "_now_fn", "_now", "altered")

    def __init__(self, now_fn: NowFn) -> None:
        self.missing: list[str] = []
        self.altered = False
        self._now_fn = now_fn
        self._now: tuple[int, int] | None = None

    def now(self) -> dict[str, int]:
        if self._now is None:
            self._now = self._now_fn()
        secs, nsecs = self._now
        return {"secs": secs, "nsecs": nsecs}


Conv = Callable[[Any, str, _Ctx], Any]
Fill = Callable[[_Ctx], Any]


def wall_now() -> tuple[int, int]:
    """Current wall-clock time as ``(secs, nsecs)``."""
    secs, nsecs = divmod(time.time_ns(), _NSEC)
    return secs, nsecs


def _zero_now() -> tuple[int, int]:
    return 0, 0


def _where(path: str) -> str:
    return f"field '{path}'" if path else "message"


def _wrong(path: str, expected: str, value: object) -> ConversionError:
    got = _JSON_NAMES.get(type(value), type(value).__name__)
    return ConversionError(f"{_where(path)} must be {expected}, got {got}")


def _to_int(value: object, path: str) -> int:
    if type(value) is int:
        return value
    if type(value) is float and value.is_integer():
        return int(value)
    raise _wrong(path, "an integer", value)


# --- scalars ---------------------------------------------------------------------------------


def _float(value: Any, path: str, ctx: _Ctx) -> float:
    kind = type(value)
    if kind is float:
        return value
    if kind is int:
        ctx.altered = True
        return float(value)
    if value is None:
        ctx.altered = True
        return _NAN
    raise _wrong(path, "a number", value)


def _string(value: Any, path: str, ctx: _Ctx) -> str:
    if type(value) is str:
        return value
    raise _wrong(path, "a string", value)


def _bool(value: Any, path: str, ctx: _Ctx) -> bool:
    if type(value) is bool:
        return value
    raise _wrong(path, "a boolean", value)


def _int_conv(typ: str) -> Conv:
    lo, hi = _INT_RANGES[typ]

    def conv(value: Any, path: str, ctx: _Ctx) -> int:
        if type(value) is int:
            number = value
        else:
            number = _to_int(value, path)
            ctx.altered = True
        if lo <= number <= hi:
            return number
        raise ConversionError(
            f"{_where(path)} value {number} is out of range for {typ} [{lo}, {hi}]"
        )

    return conv


def _time_conv(typ: str) -> Conv:
    lo, hi = _SECS_RANGE[typ]
    expected = _TIME_EXPECTED[typ]
    accepts_now = typ == "time"

    def conv(value: Any, path: str, ctx: _Ctx) -> dict[str, int]:
        kind = type(value)
        if kind is dict:
            secs = nsecs = None
            if len(value) != 2 or type(value.get("secs")) is not int:
                ctx.altered = True  # not {secs, nsecs} as ints: renamed, retyped or filled
            elif type(value.get("nsecs")) is not int:
                ctx.altered = True
            for key, part in value.items():
                if key in ("secs", "sec"):
                    secs = _to_int(part, f"{path}.{key}")
                elif key in ("nsecs", "nanosec", "nsec"):
                    nsecs = _to_int(part, f"{path}.{key}")
                else:
                    raise ConversionError(f"unknown field '{path}.{key}' for type {typ}")
            if secs is None:
                secs = 0
                ctx.missing.append(f"{path}.secs")
            if nsecs is None:
                nsecs = 0
                ctx.missing.append(f"{path}.nsecs")
        elif kind is int or kind is float:
            if not math.isfinite(value):
                raise ConversionError(f"{_where(path)} must be a finite number of seconds")
            whole = math.floor(value)
            secs, nsecs = int(whole), round((value - whole) * _NSEC)
            ctx.altered = True
        elif accepts_now and value == "now":
            ctx.altered = True
            return ctx.now()
        else:
            raise _wrong(path, expected, value)
        carry, nsecs = divmod(nsecs, _NSEC)
        if carry:
            ctx.altered = True
        secs += carry
        if not lo <= secs <= hi:
            raise ConversionError(f"{_where(path)} seconds {secs} out of range for {typ}")
        return {"secs": secs, "nsecs": nsecs}

    return conv


def _zero_time(ctx: _Ctx) -> dict[str, int]:
    return {"secs": 0, "nsecs": 0}


# --- arrays ----------------------------------------------------------------------------------


def _check_array(value: Any, path: str, length: int) -> None:
    if type(value) is not list and type(value) is not tuple:
        raise _wrong(path, "an array", value)
    if length and len(value) != length:
        raise ConversionError(
            f"{_where(path)} must have exactly {length} elements, got {len(value)}"
        )


def _each(elem: Conv, value: Any, path: str, ctx: _Ctx) -> list[Any]:
    return [elem(item, f"{path}[{i}]", ctx) for i, item in enumerate(value)]


def _float_array(length: int, narrow: bool = False) -> Conv:
    """``narrow``: a float32 field, whose big float32 arrays (a CBOR typed array, CDR) stay
    float32 rather than widened: half the memory, and a JSON text of half the length (each
    value as the shortest text of its float32, which a float32 field reads back exactly)."""

    def conv(value: Any, path: str, ctx: _Ctx) -> list[float] | np.ndarray:
        if type(value) is np.ndarray:
            ctx.altered = True
            if narrow and value.dtype == np.float32 and value.ndim == 1 and \
                    len(value) >= BIG_ARRAY and (not length or len(value) == length):
                return value
            value = _float_ndarray(value, path, length)
            if type(value) is np.ndarray:
                return value
        _check_array(value, path, length)
        if countOf(map(type, value), float) == len(value):  # the common case, 30% faster
            return list(value)
        ctx.altered = True
        kinds = set(map(type, value))
        if kinds <= _FLOAT_LIKE:
            return [_NAN if x is None else float(x) for x in value]
        return _each(_float, value, path, ctx)

    return conv


def _numeric(value: np.ndarray, path: str, length: int) -> str:
    """The dtype kind ('i', 'u', 'f') of a 1-D numeric array of the right length, else ''."""
    if value.ndim != 1 or value.dtype.kind not in "iuf":
        return ""
    if length and len(value) != length:
        raise ConversionError(
            f"{_where(path)} must have exactly {length} elements, got {len(value)}"
        )
    return value.dtype.kind


def _float_ndarray(value: np.ndarray, path: str, length: int) -> np.ndarray | list:
    if not _numeric(value, path, length):
        return value.tolist()
    wide = value.astype(np.float64, copy=False)
    return wide if len(wide) >= BIG_ARRAY else wide.tolist()


def _integral(value: np.ndarray, path: str, length: int) -> np.ndarray | None:
    """An integer-valued array, or None when some element is not an integer."""
    kind = _numeric(value, path, length)
    if kind == "f":
        if not np.isfinite(value).all() or (value != np.trunc(value)).any():
            return None
        return value.astype(np.int64)  # |x| beyond 2**63 then fails the range check below
    return value if kind else None


# Integer arrays at least this long (maps, images as int8) are checked and stored with numpy:
# half the time of Python's min/max, and 1 byte per int8 cell instead of a 32-byte list slot.
BIG_ARRAY = 4096
_NUMPY_INTS = {
    "int8": np.int8, "byte": np.int8, "int16": np.int16, "uint16": np.uint16,
    "int32": np.int32, "uint32": np.uint32, "int64": np.int64,
}


def _int_array(typ: str, length: int) -> Conv:
    lo, hi = _INT_RANGES[typ]
    elem = _int_conv(typ)
    dtype = _NUMPY_INTS.get(typ)

    def conv(value: Any, path: str, ctx: _Ctx) -> list[int] | np.ndarray:
        if type(value) is np.ndarray:
            ctx.altered = True
            ints = _integral(value, path, length)
            if ints is not None and (not len(ints) or lo <= ints.min() and ints.max() <= hi):
                if dtype is not None and len(ints) >= BIG_ARRAY:
                    return ints.astype(dtype)
                return ints.tolist()
            value = value.tolist()  # the list path names the offending element
        _check_array(value, path, length)
        if set(map(type, value)) <= _ONLY_INT:
            if dtype is not None and len(value) >= BIG_ARRAY:
                wide = np.fromiter(value, dtype=np.int64, count=len(value))
                if lo <= wide.min() and wide.max() <= hi:
                    return wide.astype(dtype)
            elif not value or (lo <= min(value) and max(value) <= hi):
                return list(value)
        return _each(elem, value, path, ctx)

    return conv


def _simple_array(elem: Conv, fast: type, length: int) -> Conv:
    """Arrays whose elements need no conversion when they already have the ``fast`` type."""
    only = frozenset({fast})

    def conv(value: Any, path: str, ctx: _Ctx) -> list[Any]:
        if type(value) is np.ndarray:
            ctx.altered = True
            value = value.tolist()
        _check_array(value, path, length)
        if set(map(type, value)) <= only:
            return list(value)
        return _each(elem, value, path, ctx)

    return conv


def _list_array(elem: Conv, length: int) -> Conv:
    def conv(value: Any, path: str, ctx: _Ctx) -> list[Any]:
        if type(value) is np.ndarray:
            ctx.altered = True
            value = value.tolist()
        _check_array(value, path, length)
        return _each(elem, value, path, ctx)

    return conv


def _signed_byte(value: Any, path: str, ctx: _Ctx) -> int:
    number = value if type(value) is int else _to_int(value, path)
    if -128 <= number <= 255:
        return number & 0xFF
    raise ConversionError(f"{_where(path)} value {number} is out of range for int8 or uint8 "
                          "[-128, 255]")


def _bytes_array(typ: str, length: int, signed: bool = False) -> Conv:
    """``signed``: integers -128..127 are accepted too, as the bytes they encode (the seed's
    ``int8[]`` spelling, :data:`.aliases.SIGNED_BYTES`)."""
    elem = _signed_byte if signed else _int_conv(typ)

    def conv(value: Any, path: str, ctx: _Ctx) -> bytes:
        ctx.altered = True  # bytes, sent as base64 whatever the client sent
        if type(value) is np.ndarray:
            ints = _integral(value, path, 0)
            if ints is not None and (not len(ints) or ints.min() >= 0 and ints.max() <= 255):
                value = ints.astype(np.uint8).tobytes()
            else:
                value = value.tolist()
        kind = type(value)
        if kind is str:
            try:
                data = base64.b64decode(value, validate=True)
            except (binascii.Error, ValueError) as exc:
                raise ConversionError(f"{_where(path)} is not valid base64: {exc}") from None
        elif kind is list or kind is tuple:
            try:
                data = bytes(value) if set(map(type, value)) <= _ONLY_INT else None
            except ValueError:
                data = None
            if data is None:
                data = bytes(_each(elem, value, path, ctx))
        elif kind is bytes or kind is bytearray:
            data = bytes(value)
        else:
            raise _wrong(path, "a base64 string or an array of integers 0-255", value)
        if length and len(data) != length:
            raise ConversionError(
                f"{_where(path)} must have exactly {length} elements, got {len(data)}"
            )
        return data

    return conv


# --- plans -----------------------------------------------------------------------------------


def _scalar_plan(typ: str) -> tuple[Conv, object]:
    """Converter and (immutable) default for a base type other than time/duration."""
    if typ in _FLOATS:
        return _float, 0.0
    if typ in _INT_RANGES:
        return _int_conv(typ), 0
    if typ == "bool":
        return _bool, False
    if typ == "string":
        return _string, ""
    raise ValueError(f"unsupported base type {typ!r}")


def _const_fill(default: object) -> Fill:
    return lambda ctx: default


def _field_plan(field: Field, reg: TypeRegistry, owner: str = "") -> tuple[Conv, Fill]:
    length = field.array
    if field.is_msg or field.type in _SECS_RANGE:
        if field.is_msg:
            elem, efill = _plan(reg.msg(field.type), reg)
        else:
            elem, efill = _time_conv(field.type), _zero_time
        if length is None:
            return elem, efill
        if length:
            return _list_array(elem, length), lambda ctx: [efill(ctx) for _ in range(length)]
        return _list_array(elem, 0), lambda ctx: []
    if length is None:
        conv, default = _scalar_plan(field.type)
        return conv, _const_fill(default)
    if field.type in _BYTE_ARRAYS:
        signed = (owner, field.name) in SIGNED_BYTES
        return _bytes_array(field.type, length, signed), _const_fill(bytes(length))
    elem, default = _scalar_plan(field.type)
    if field.type in _FLOATS:
        conv = _float_array(length, field.type == "float32")
    elif field.type in _INT_RANGES:
        conv = _int_array(field.type, length)
    else:
        conv = _simple_array(elem, type(default), length)
    return conv, lambda ctx: [default] * length


def _plan(mtype: MsgType, reg: TypeRegistry) -> tuple[Conv, Fill]:
    plans = reg.plans["json"]
    plan = plans.get(mtype.name)
    if plan is None:
        plan = plans[mtype.name] = _build(mtype, reg)
    return plan


def _unalias(value: dict, aliases: dict[str, str], prefix: str) -> dict:
    """``value`` with the seed's field names replaced by the SDK's (:mod:`.aliases`)."""
    out = dict(value)
    for seed, sdk in aliases.items():
        if seed in out:
            if sdk in out:
                raise ConversionError(f"fields '{prefix}{seed}' and '{prefix}{sdk}' are two "
                                      "spellings of one field; send one")
            out[sdk] = out.pop(seed)
    return out


def _is_optional(mtype: MsgType) -> bool:
    """A Slamware ``Optional*`` wrapper (``is_valid`` + ``value``): omitted, its default says
    "not given", which is what the sender meant, so it is not reported as missing."""
    return [f.name for f in mtype.fields] == ["is_valid", "value"]


def _build(mtype: MsgType, reg: TypeRegistry) -> tuple[Conv, Fill]:
    is_header = mtype.name == HEADER
    entries: list[tuple[str, Conv, Fill, bool]] = []
    for field in mtype.fields:
        conv, fill = _field_plan(field, reg, mtype.name)
        report = not (field.type == HEADER and field.array is None)
        if field.name == "stamp" and field.type == "time" and field.array is None:
            report = False
        if field.is_msg and field.array is None and _is_optional(reg.msg(field.type)):
            report = False
        if is_header and field.name in ("seq", "stamp"):
            report = False
            if field.name == "stamp":
                fill = _Ctx.now
        entries.append((field.name, conv, fill, report))
    names = frozenset(name for name, _, _, _ in entries)
    short = TypeRegistry.short(mtype.name)
    expected = f"an object ({short})"

    aliases = FIELD_ALIASES.get(mtype.name)

    def conv(value: Any, path: str, ctx: _Ctx) -> dict[str, Any]:
        if type(value) is not dict:
            raise _wrong(path, expected, value)
        prefix = f"{path}." if path else ""
        if aliases and not aliases.keys().isdisjoint(value):
            value = _unalias(value, aliases, prefix)
            ctx.altered = True  # renamed: the client's own text is not the canonical message
        out: dict[str, Any] = {}
        seen = 0
        for name, fconv, ffill, report in entries:
            item = value.get(name, _MISSING)
            if item is _MISSING:
                out[name] = ffill(ctx)
                ctx.altered = True
                if report:
                    ctx.missing.append(prefix + name)
            else:
                seen += 1
                out[name] = fconv(item, prefix + name, ctx)
        if seen != len(value):
            unknown = next(key for key in value if key not in names)
            raise ConversionError(f"unknown field '{prefix}{unknown}' for type {short}")
        return out

    def fill(ctx: _Ctx) -> dict[str, Any]:
        return {name: ffill(ctx) for name, _, ffill, _ in entries}

    return conv, fill


def default_message(mtype: MsgType, reg: TypeRegistry) -> dict[str, Any]:
    """A message with every field at its default (zeros, empty, stamps 0)."""
    return _plan(mtype, reg)[1](_Ctx(_zero_now))


def from_json(
    mtype: MsgType,
    value: object,
    reg: TypeRegistry,
    *,
    now: NowFn | None = None,
) -> tuple[dict[str, Any], list[str]]:
    """Validate ``value`` (JSON-decoded; ``None`` means ``{}``) and return the canonical message
    plus the paths of fields that were omitted and filled with defaults.

    Raises :class:`ConversionError` naming the offending field path.
    """
    msg, missing, _ = from_json_verbatim(mtype, value, reg, now=now)
    return msg, missing


def from_json_verbatim(
    mtype: MsgType,
    value: object,
    reg: TypeRegistry,
    *,
    now: NowFn | None = None,
) -> tuple[dict[str, Any], list[str], bool]:
    """Like :func:`from_json`, plus whether the canonical message *is* ``value`` as JSON (no
    field filled, retyped or renamed), so that the client's own text of it may be sent on."""
    ctx = _Ctx(now or wall_now)
    msg = _plan(mtype, reg)[0]({} if value is None else value, "", ctx)
    return msg, ctx.missing, not ctx.altered and value is not None

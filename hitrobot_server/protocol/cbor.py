"""rosbridge's ``cbor`` compression: type-directed CBOR with RFC 8746 typed arrays.

Numeric arrays travel as little-endian packed bytes under a typed-array tag, which roslibjs turns
straight into JS typed arrays. Unlike rosbridge we also tag fixed-size arrays (``float64[9]``
crashed rosbridge, #864) and accept numpy arrays anywhere a list is allowed.
"""

from __future__ import annotations

from typing import Any

import cbor2
import numpy as np

from hitrobot_server.types import jsoncodec
from hitrobot_server.types.registry import MsgType, TypeRegistry

from .fieldplan import Build, Entries, Leaves, compile_plan

# ROS base type → (RFC 8746 tag, little-endian numpy dtype). uint8/char go out as byte strings.
_TYPED_ARRAYS = {
    "uint16": (69, "<u2"),
    "uint32": (70, "<u4"),
    "uint64": (71, "<u8"),
    "int8": (72, "i1"),
    "byte": (72, "i1"),
    "int16": (77, "<i2"),
    "int32": (78, "<i4"),
    "int64": (79, "<i8"),
    "float32": (85, "<f4"),
    "float64": (86, "<f8"),
}
# Every RFC 8746 typed-array tag numpy can represent, for decoding what peers send.
_TAG_DTYPES = {
    64: "u1",
    65: ">u2",
    66: ">u4",
    67: ">u8",
    68: "u1",
    69: "<u2",
    70: "<u4",
    71: "<u8",
    72: "i1",
    73: ">i2",
    74: ">i4",
    75: ">i8",
    77: "<i2",
    78: "<i4",
    79: "<i8",
    80: ">f2",
    81: ">f4",
    82: ">f8",
    84: "<f2",
    85: "<f4",
    86: "<f8",
}
_INTS = frozenset(
    {"int8", "byte", "uint8", "char", "int16", "uint16", "int32", "uint32", "int64", "uint64"}
)


def _as_bytes(value: Any) -> bytes:
    if type(value) is bytes:
        return value
    if isinstance(value, bytearray | memoryview):
        return bytes(value)
    return np.asarray(value, dtype=np.uint8).tobytes()


def _time(value: Any) -> dict[str, int]:
    return {"secs": int(value["secs"]), "nsecs": int(value["nsecs"])}


def _time_encoder(_typ: str, _reg: TypeRegistry) -> Build:
    return _time


def _scalar_encoder(typ: str) -> Build:
    if typ in ("float32", "float64"):
        return float
    if typ in _INTS:
        return int
    if typ == "bool":
        return bool
    return str


def _typed_array(tag: int, dtype: str) -> Build:
    return lambda value: cbor2.CBORTag(tag, np.asarray(value, dtype=dtype).tobytes())


def _array_encoder(field_type: str) -> Build:
    if field_type in ("uint8", "char"):
        return _as_bytes
    if field_type in _TYPED_ARRAYS:
        return _typed_array(*_TYPED_ARRAYS[field_type])
    if field_type == "bool":
        return lambda value: [bool(x) for x in value]
    return lambda value: [str(x) for x in value]


def _message_encoder(_mtype: MsgType, entries: Entries, _reg: TypeRegistry) -> Build:
    def encode(msg: dict[str, Any]) -> dict[str, Any]:
        return {name: enc(msg[name]) for name, enc in entries}

    return encode


_LEAVES = Leaves("cbor", _scalar_encoder, _time_encoder, _array_encoder, _message_encoder)


def to_cbor_value(msg: dict[str, Any], mtype: MsgType, reg: TypeRegistry) -> dict[str, Any]:
    """Canonical message → values that ``cbor2.dumps`` encodes the way rosbridge clients expect."""
    return compile_plan(mtype, reg, _LEAVES)(msg)


def encode_publish_cbor(
    topic: str, msg: dict[str, Any], mtype: MsgType, reg: TypeRegistry
) -> bytes:
    """A complete binary ``publish`` frame for a ``compression: cbor`` subscriber."""
    return cbor2.dumps({"op": "publish", "topic": topic, "msg": to_cbor_value(msg, mtype, reg)})


def typed_array(tag: cbor2.CBORTag) -> np.ndarray | None:
    """The numpy array an RFC 8746 typed-array tag holds (None for any other tag): a view on
    its bytes (a copy in native order for big-endian tags), never one Python object per
    element, so it takes no more memory than the frame it came in."""
    dtype = _TAG_DTYPES.get(tag.tag)
    if dtype is None or not isinstance(tag.value, bytes):
        return None
    kind = np.dtype(dtype)
    if len(tag.value) % kind.itemsize:
        raise jsoncodec.InvalidValue(
            f"a typed array (CBOR tag {tag.tag}) of {len(tag.value)} bytes is not a whole "
            f"number of {kind.itemsize}-byte items")
    array = np.frombuffer(tag.value, dtype=kind)
    return array if kind.isnative or kind.itemsize == 1 else array.astype(kind.newbyteorder("="))


def decode_typed_arrays(obj: Any) -> Any:
    """Replace RFC 8746 typed-array tags (as left by ``cbor2.loads``) with numpy arrays, in
    place and without recursion."""
    if isinstance(obj, cbor2.CBORTag):
        found = typed_array(obj)
        return obj if found is None else found
    stack = [obj]
    while stack:
        node = stack.pop()
        if type(node) is dict:
            items = node.items()
        elif type(node) is list:
            items = enumerate(node)
        else:
            continue
        for key, value in items:
            if type(value) is dict or type(value) is list:
                stack.append(value)
            elif type(value) is cbor2.CBORTag and (found := typed_array(value)) is not None:
                node[key] = found
    return obj


def decode(data: bytes) -> Any:
    """Decode a CBOR frame with typed arrays turned into numpy arrays.

    Raises ``cbor2.CBORDecodeError`` when malformed (cbor2 bounds nesting itself) and
    :class:`~hitrobot_server.types.jsoncodec.InvalidValue` for values the server cannot carry
    (integers beyond 64 bits, other tags, undefined, non-string keys).
    """
    obj = cbor2.loads(data)
    try:
        obj = decode_typed_arrays(obj)
    except jsoncodec.InvalidValue as exc:
        raise jsoncodec.InvalidValue(str(exc), jsoncodec.top_id(obj)) from None
    jsoncodec.check_value(obj, allow_bytes=True)
    return obj

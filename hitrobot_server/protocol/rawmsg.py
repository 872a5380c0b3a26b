"""rosbridge's ``cbor-raw`` compression: ROS 1 wire bytes of the message inside a CBOR frame.

Clients decode the bytes themselves using the definitions from
``/rosapi/topics_and_raw_types``; serialisation is delegated to the rosbags typestore, so the
canonical dict is first rebuilt as rosbags message objects.
"""

from __future__ import annotations

from typing import Any

import cbor2
import numpy as np

from hitrobot_server.types.registry import (
    NUMPY_DTYPES,
    ROSBAGS_TIME_TYPES,
    MsgType,
    TypeRegistry,
)

from .fieldplan import Build, Entries, Leaves, compile_plan


def _identity(value: Any) -> Any:
    return value


def _numeric_array(dtype: type[np.generic]) -> Build:
    def build(value: Any) -> np.ndarray:
        if isinstance(value, bytes | bytearray | memoryview):
            return np.frombuffer(value, dtype=dtype)
        return np.asarray(value, dtype=dtype)

    return build


def _time_builder(field_type: str, reg: TypeRegistry) -> Build:
    cls = reg.typestore.types[ROSBAGS_TIME_TYPES[field_type]]
    return lambda value: cls(sec=int(value["secs"]), nanosec=int(value["nsecs"]))


def _scalar_builder(_field_type: str) -> Build:
    return _identity


def _array_builder(field_type: str) -> Build:
    if field_type == "string":
        return list
    return _numeric_array(NUMPY_DTYPES[field_type])


def _message_builder(mtype: MsgType, entries: Entries, reg: TypeRegistry) -> Build:
    cls = reg.typestore.types[mtype.name]

    def make(msg: dict[str, Any]) -> Any:
        return cls(**{name: build(msg[name]) for name, build in entries})

    return make


_LEAVES = Leaves("ros1", _scalar_builder, _time_builder, _array_builder, _message_builder)


def serialize_ros1(msg: dict[str, Any], mtype: MsgType, reg: TypeRegistry) -> bytes:
    """ROS 1 wire bytes of a canonical message (as rosbags objects first)."""
    return bytes(reg.typestore.serialize_ros1(compile_plan(mtype, reg, _LEAVES)(msg), mtype.name))


def encode_publish_cbor_raw(
    topic: str,
    msg: dict[str, Any],
    mtype: MsgType,
    reg: TypeRegistry,
    stamp: tuple[int, int],
) -> bytes:
    """A complete binary ``publish`` frame for a ``compression: cbor-raw`` subscriber.

    ``stamp`` is the receipt time ``(secs, nsecs)`` rosbridge puts next to the bytes.
    """
    secs, nsecs = stamp
    raw = {"secs": secs, "nsecs": nsecs, "bytes": serialize_ros1(msg, mtype, reg)}
    return cbor2.dumps({"op": "publish", "topic": topic, "msg": raw})

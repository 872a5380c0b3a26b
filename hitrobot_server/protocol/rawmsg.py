"""rosbridge's ``cbor-raw`` compression: ROS 1 wire bytes of the message inside a CBOR frame.

Clients decode the bytes themselves using the definitions from
``/rosapi/topics_and_raw_types``; serialisation is delegated to the rosbags typestore, so the
canonical dict is first rebuilt as rosbags message objects.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import cbor2
import numpy as np

from hitrobot_server.types.registry import (
    NUMPY_DTYPES,
    ROSBAGS_TIME_TYPES,
    MsgType,
    TypeRegistry,
)

Builder = Callable[[Any], Any]



def _identity(value: Any) -> Any:
    return value


def _numeric_array(dtype: type[np.generic]) -> Builder:
    def build(value: Any) -> np.ndarray:
        if isinstance(value, bytes | bytearray | memoryview):
            return np.frombuffer(value, dtype=dtype)
        return np.asarray(value, dtype=dtype)

    return build


def _time_builder(cls: Any) -> Builder:
    return lambda value: cls(sec=int(value["secs"]), nanosec=int(value["nsecs"]))


def _field_builder(field_type: str, is_msg: bool, array: int | None, reg: TypeRegistry) -> Builder:
    if is_msg:
        elem = _plan(reg.msg(field_type), reg)
    elif field_type in ROSBAGS_TIME_TYPES:
        elem = _time_builder(reg.typestore.types[ROSBAGS_TIME_TYPES[field_type]])
    elif array is None:
        return _identity
    elif field_type == "string":
        return list
    else:
        return _numeric_array(NUMPY_DTYPES[field_type])
    if array is None:
        return elem
    return lambda value: [elem(x) for x in value]


def _plan(mtype: MsgType, reg: TypeRegistry) -> Builder:
    plans = reg.plan_cache("ros1")
    plan = plans.get(mtype.name)
    if plan is None:
        cls = reg.typestore.types[mtype.name]
        entries = tuple(
            (f.name, _field_builder(f.type, f.is_msg, f.array, reg)) for f in mtype.fields
        )

        def plan(msg: dict[str, Any]) -> Any:
            return cls(**{name: build(msg[name]) for name, build in entries})

        plans[mtype.name] = plan
    return plan


def serialize_ros1(msg: dict[str, Any], mtype: MsgType, reg: TypeRegistry) -> bytes:
    """ROS 1 wire bytes of a canonical message."""
    return bytes(reg.typestore.serialize_ros1(_plan(mtype, reg)(msg), mtype.name))


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

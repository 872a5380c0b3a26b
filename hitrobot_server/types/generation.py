"""Which ROS generation a type belongs to, and its times spelled as that generation's.

Inside the server a time or duration is ROS 1's ``{secs, nsecs}``, and so it goes out to a
rosbridge client. A type only ROS 2 has goes out as ROS 2 spells it, ``{sec, nanosec}``
(``builtin_interfaces``), nested messages included, since a ROS 2 client reads only that: a
type of a package ROS 1 never had (:data:`ROS2_PACKAGES`), a ROS 2 action's own interfaces
(``X_SendGoal_Request``, ``X_GetResult_Response``, ``X_FeedbackMessage``: the ``_action/``
services and topics), and whatever the ROS 2 action ops carry (the session decides that).
Clients may send either spelling; :mod:`.convert` takes both.
"""

from __future__ import annotations

from functools import cache
from typing import Any

from .registry import MsgType, TypeRegistry

ROS2_PACKAGES = frozenset({"action_msgs", "builtin_interfaces", "nav2_msgs", "rcl_interfaces",
                           "unique_identifier_msgs"})
_ROS2_PARTS = ("_SendGoal_", "_GetResult_", "_FeedbackMessage")
_TIMES = ("time", "duration")


def is_ros2(type_name: str) -> bool:
    """Whether a type (message or service, any spelling) exists only in ROS 2."""
    return (type_name.split("/", 1)[0] in ROS2_PACKAGES
            or any(part in type_name for part in _ROS2_PARTS))


@cache
def _has_times(mtype: MsgType, types: TypeRegistry) -> bool:
    return any(f.type in _TIMES or (f.is_msg and _has_times(types.msg(f.type), types))
               for f in mtype.fields)


def ros2_times(value: dict, mtype: MsgType, types: TypeRegistry) -> dict:
    """``value`` (a message of ``mtype``) with every time and duration as ``{sec, nanosec}``;
    ``value`` itself when it holds none (a copy otherwise: the bus's message is shared)."""
    if not _has_times(mtype, types) or not isinstance(value, dict):
        return value
    out = dict(value)
    for f in mtype.fields:
        item = out.get(f.name)
        if item is None:
            continue
        if f.type in _TIMES:
            out[f.name] = [_spelled(t) for t in item] if f.array is not None else _spelled(item)
        elif f.is_msg:
            inner = types.msg(f.type)
            out[f.name] = ([ros2_times(v, inner, types) for v in item] if f.array is not None
                           else ros2_times(item, inner, types))
    return out


def _spelled(stamp: Any) -> Any:
    if isinstance(stamp, dict) and "secs" in stamp:
        return {"sec": stamp["secs"], "nanosec": stamp.get("nsecs", 0)}
    return stamp

"""One compiler of per-type encoders for the binary compressions (cbor.py, rawmsg.py).

Walking a message type's fields for every message would cost more than the encoding itself,
so a type is compiled once per registry into one function that builds each field with the
builder its kind needs. What differs between encodings is only the leaves (:class:`Leaves`):
how a scalar, a time, a primitive array and a whole message are built; nested messages and
arrays of them are walked here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..types.registry import Field, MsgType, TypeRegistry

Build = Callable[[Any], Any]
Entries = tuple[tuple[str, Build], ...]


@dataclass(frozen=True, slots=True)
class Leaves:
    """What one encoding makes of each kind of field."""

    kind: str  # the registry's plan cache this encoding compiles into
    scalar: Callable[[str], Build]  # a primitive field, by ROS type
    time: Callable[[str, TypeRegistry], Build]  # ``time`` or ``duration``
    array: Callable[[str], Build]  # a whole array of a primitive type
    message: Callable[[MsgType, Entries, TypeRegistry], Build]  # a message from its fields


def compile_plan(mtype: MsgType, reg: TypeRegistry, leaves: Leaves) -> Build:
    """The encoder of ``mtype`` for ``leaves``, compiled on first use and kept in ``reg``."""
    plans = reg.plans[leaves.kind]
    plan = plans.get(mtype.name)
    if plan is None:
        entries = tuple((f.name, _field(f, reg, leaves)) for f in mtype.fields)
        plan = plans[mtype.name] = leaves.message(mtype, entries, reg)
    return plan


def _field(field: Field, reg: TypeRegistry, leaves: Leaves) -> Build:
    if field.is_msg:
        elem = compile_plan(reg.msg(field.type), reg, leaves)
    elif field.type in ("time", "duration"):
        elem = leaves.time(field.type, reg)
    elif field.array is None:
        return leaves.scalar(field.type)
    else:
        return leaves.array(field.type)
    if field.array is None:
        return elem
    return lambda value: [elem(x) for x in value]

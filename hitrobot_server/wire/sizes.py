"""Sizes known before encoding: what decides whether an op is built inline or in the worker
pool (``protocol.bulk.OFFLOAD_BYTES``), and what a queue charges for a message meanwhile."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..types.registry import MsgType, TypeRegistry


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


def has_lists(mtype: MsgType, reg: TypeRegistry) -> bool:
    """Whether a message of this type can hold a variable-length array (at any depth); one
    that cannot (Twist, Odometry, String, ...) is never big enough to leave the event loop."""
    memo: dict[str, Any] = reg.plan_cache("has_lists")
    found = memo.get(mtype.name)
    if found is None:
        memo[mtype.name] = False  # a recursive type cannot loop forever here
        found = memo[mtype.name] = any(
            f.array == 0 or (f.is_msg and has_lists(reg.msg(f.type), reg)) for f in mtype.fields
        )
    return found

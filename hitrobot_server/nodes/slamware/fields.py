"""The Slamware requests' fields, checked (pure): a refused field raises RequestRejected
naming it, as the publisher hears it."""

from __future__ import annotations

import math
from typing import Any

from ...bus.topics import RequestRejected
from ...robot.model import ArtifactUsage, Line, MoveOptionFlag, MoveOptions, Point2D
from ..base import require_finite
from ..ground import messages as m

KNOWN_FLAGS = 0xFF | 512 | 1024 | 2048  # the ROS msg's bits plus the SDK's newer ones


def enum_field(path: str, value: int, enum_type) -> Any:
    try:
        member = enum_type(value)
    except ValueError:
        member = None
    if member is None or value < 0:
        names = ", ".join(f"{e.name}={e.value}" for e in enum_type if e.value >= 0)
        raise RequestRejected(f"field '{path}' must be one of {names}, got {value}")
    return member


def move_options(msg: dict, path: str = "options") -> MoveOptions:
    flags = msg["opt_flags"]["flags"]
    if flags & ~KNOWN_FLAGS:
        raise RequestRejected(f"field '{path}.opt_flags.flags' has unknown bits {flags:#x}")
    ratio = msg["speed_ratio"]
    speed = None
    if ratio["is_valid"]:
        require_finite(f"{path}.speed_ratio.value", ratio["value"])
        if not 0.0 < ratio["value"] <= 1.0:
            raise RequestRejected(f"field '{path}.speed_ratio.value' must be in (0, 1]")
        speed = float(ratio["value"])
    return MoveOptions(flags=MoveOptionFlag(flags), speed_ratio=speed)


def point(msg: dict, path: str) -> Point2D:
    require_finite(path, msg["x"], msg["y"])
    return Point2D(float(msg["x"]), float(msg["y"]))


def quaternion_yaw(q: dict, path: str) -> float:
    require_finite(path, q["x"], q["y"], q["z"], q["w"])
    return m.yaw_of(q)


def line(msg: dict, path: str) -> Line:
    start, end = point(msg["start"], f"{path}.start"), point(msg["end"], f"{path}.end")
    if math.hypot(end.x - start.x, end.y - start.y) < 1e-6:
        raise RequestRejected(f"field '{path}' is a line of zero length")
    return Line(int(msg["id"]), start, end)


def lines(msg: dict) -> list[Line]:
    return [line(x, f"lines[{i}]") for i, x in enumerate(msg["lines"])]


def usage(msg: dict) -> ArtifactUsage:
    return enum_field("usage.usage", msg["usage"]["usage"], ArtifactUsage)

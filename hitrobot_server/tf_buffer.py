"""A transform tree built from ``/tf`` and ``/tf_static``: the latest transform of every frame.

This is the part of a tf2 buffer a republisher needs: "where is frame A in frame B now",
composed along the tree (``map → odom → base_link``). It keeps the latest transform per child
frame, not a history, so lookups are always "latest" (tf2's ``Time(0)``) and the answer is
stamped with the oldest stamp along the chain, as tf2 does. Pure: no bus, no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

MAX_DEPTH = 64
"""Longest parent chain followed; a longer one (or a loop) is treated as unknown."""

Vec = tuple[float, float, float]
Quat = tuple[float, float, float, float]  # x, y, z, w


def frame_name(frame: str) -> str:
    """tf2 frame ids carry no leading slash; ``/map`` and ``map`` are the same frame."""
    return frame.lstrip("/")


def _qmul(a: Quat, b: Quat) -> Quat:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def _rotate(q: Quat, v: Vec) -> Vec:
    x, y, z, w = q
    tx, ty, tz = 2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])
    return (v[0] + w * tx + y * tz - z * ty,
            v[1] + w * ty + z * tx - x * tz,
            v[2] + w * tz + x * ty - y * tx)


def _normalized(q: Quat) -> Quat:
    n = math.sqrt(sum(c * c for c in q))
    return (0.0, 0.0, 0.0, 1.0) if n == 0.0 or not math.isfinite(n) else tuple(c / n for c in q)


@dataclass(frozen=True, slots=True)
class Transform:
    """A rigid transform ``parent ← child`` (the child's pose in the parent), with its stamp."""

    translation: Vec = (0.0, 0.0, 0.0)
    rotation: Quat = (0.0, 0.0, 0.0, 1.0)
    stamp: float = 0.0

    def __mul__(self, other: Transform) -> Transform:
        """``a * b``: ``b`` expressed in ``a``'s parent (apply ``b``, then ``a``)."""
        moved = _rotate(self.rotation, other.translation)
        return Transform(
            tuple(s + m for s, m in zip(self.translation, moved, strict=True)),
            _normalized(_qmul(self.rotation, other.rotation)),
            min(self.stamp, other.stamp),
        )

    def inverse(self) -> Transform:
        x, y, z, w = self.rotation
        conj = (-x, -y, -z, w)
        t = _rotate(conj, self.translation)
        return Transform((-t[0], -t[1], -t[2]), conj, self.stamp)

    def distance_to(self, other: Transform) -> float:
        return math.dist(self.translation, other.translation)

    def angle_to(self, other: Transform) -> float:
        """The rotation angle between the two orientations (radians, 0..π)."""
        dot = abs(sum(a * b for a, b in zip(self.rotation, other.rotation, strict=True)))
        return 2.0 * math.acos(min(1.0, dot))


def transform_of(msg: dict) -> Transform:
    """A ``geometry_msgs/Transform`` plus a stamp in seconds."""
    t, r = msg["translation"], msg["rotation"]
    return Transform((float(t["x"]), float(t["y"]), float(t["z"])),
                     _normalized((float(r["x"]), float(r["y"]), float(r["z"]), float(r["w"]))))


class TFBuffer:
    """The latest ``parent ← child`` transform of every child frame."""

    def __init__(self) -> None:
        self._parents: dict[str, tuple[str, Transform]] = {}

    def add(self, stamped: dict) -> None:
        """Take one ``geometry_msgs/TransformStamped`` (canonical dict); a frame's latest
        transform replaces the previous one, also when its parent changed."""
        parent = frame_name(stamped["header"]["frame_id"])
        child = frame_name(stamped["child_frame_id"])
        if not parent or not child or parent == child:
            return
        stamp = stamped["header"]["stamp"]
        base = transform_of(stamped["transform"])
        self._parents[child] = (parent, Transform(base.translation, base.rotation,
                                                  stamp["secs"] + stamp["nsecs"] * 1e-9))

    def frames(self) -> set[str]:
        return set(self._parents) | {parent for parent, _ in self._parents.values()}

    def _to_root(self, frame: str) -> tuple[str, Transform] | None:
        """The frame's pose in the root of its tree; None on a loop or an absurd depth."""
        pose = Transform(stamp=math.inf)
        for _ in range(MAX_DEPTH):
            link = self._parents.get(frame)
            if link is None:
                return frame, pose
            frame, step = link
            pose = step * pose
        return None

    def lookup(self, target: str, source: str) -> Transform | None:
        """``source``'s pose in ``target`` (tf2's ``lookupTransform(target, source, 0)``), or
        None when the frames are not connected. A frame in itself is the identity, known or not
        (as tf2: roslibpy's TFClient of ``world`` in ``world``)."""
        target, source = frame_name(target), frame_name(source)
        if target and target == source:
            return Transform(stamp=0.0)
        if target not in self.frames() or source not in self.frames():
            return None
        a, b = self._to_root(target), self._to_root(source)
        if a is None or b is None or a[0] != b[0]:
            return None
        found = a[1].inverse() * b[1]
        if math.isinf(found.stamp):  # source == target: no link was used
            return Transform(found.translation, found.rotation, 0.0)
        return found

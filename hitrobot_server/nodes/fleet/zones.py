"""Mutex zones: a named polygon of the site map (a door, a narrow corridor) that one robot at a
time may be in. Here: the zone, its checks (a refusal names the field) and its geometry — how
far a point is from it, which points of a path come near it."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from .tasks import Refused

MAX_ZONES = 100
MAX_POINTS = 100
MIN_AREA = 0.01  # m²: a polygon smaller than this is a mistake, not a zone
NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")
MAX_KIND = 32
CAPACITY = 1
"""Robots a zone admits at once (every zone is a mutex)."""
SITE_LIMIT = 10_000.0
"""Metres from the map origin beyond which a point is refused at once."""


@dataclass(frozen=True)
class Zone:
    name: str
    kind: str
    points: tuple[tuple[float, float], ...]  # map frame, in order, not closed

    def record(self) -> dict:
        return {"name": self.name, "kind": self.kind, "points": [list(p) for p in self.points]}

    @classmethod
    def from_record(cls, r: dict) -> Zone:
        return cls(str(r["name"]), str(r["kind"]),
                   tuple((float(x), float(y)) for x, y in r["points"]))

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Each point's distance (m) to the zone: 0 inside."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        poly = np.asarray(self.points, dtype=np.float64)
        a, b = poly, np.roll(poly, -1, axis=0)
        ab = b - a  # (M, 2)
        ap = pts[:, None, :] - a[None, :, :]  # (N, M, 2)
        denom = np.maximum((ab * ab).sum(axis=1), 1e-12)
        t = np.clip((ap * ab[None]).sum(axis=2) / denom, 0.0, 1.0)
        gap = ap - t[..., None] * ab[None]
        edge = np.sqrt((gap * gap).sum(axis=2)).min(axis=1)
        return np.where(self.contains(pts), 0.0, edge)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether each point is inside the polygon (even-odd rule)."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        poly = np.asarray(self.points, dtype=np.float64)
        x, y = pts[:, 0:1], pts[:, 1:2]
        ax, ay = poly[:, 0], poly[:, 1]
        bx, by = np.roll(ax, -1), np.roll(ay, -1)
        crosses = (ay > y) != (by > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            at = ax + (y - ay) * (bx - ax) / (by - ay)
        return ((crosses & (x < at)).sum(axis=1) % 2) == 1


def checked_zone(request: dict, grid: dict | None, taken: set[str]) -> Zone:
    """The zone a ``FleetZoneAdd`` request describes; :class:`Refused` naming the field."""
    name = str(request.get("name", "")).strip()
    if not NAME.fullmatch(name):
        raise Refused(f"name: '{name}' must be 1–64 letters, digits, '_', '-' or '.'")
    if name in taken:
        raise Refused(f"name: a zone '{name}' exists already; remove it first")
    if len(taken) >= MAX_ZONES:
        raise Refused(f"{MAX_ZONES} zones already; remove one first")
    kind = str(request.get("kind", "")).strip() or "zone"
    if len(kind) > MAX_KIND or not kind.isprintable():
        raise Refused(f"kind: at most {MAX_KIND} printable characters")
    raw = (request.get("polygon") or {}).get("points") or []
    if not 3 <= len(raw) <= MAX_POINTS:
        raise Refused(f"polygon.points: a zone needs 3 to {MAX_POINTS} points, got {len(raw)}")
    points = []
    for i, p in enumerate(raw):
        x, y = float(p.get("x", math.nan)), float(p.get("y", math.nan))
        if not (math.isfinite(x) and math.isfinite(y)):
            raise Refused(f"polygon.points[{i}]: not a finite point")
        if abs(x) > SITE_LIMIT or abs(y) > SITE_LIMIT:
            raise Refused(f"polygon.points[{i}]: ({x:g}, {y:g}) is off the map")
        points.append((x, y))
    _check_shape(points)
    _check_on_map(points, grid)
    return Zone(name, kind, tuple(points))


def _check_shape(points: list[tuple[float, float]]) -> None:
    xy = np.asarray(points)
    area = 0.5 * abs(float(np.dot(xy[:, 0], np.roll(xy[:, 1], -1))
                           - np.dot(xy[:, 1], np.roll(xy[:, 0], -1))))
    if area < MIN_AREA:
        raise Refused(f"polygon.points: the polygon's area is {area:.3g} m² (at least "
                      f"{MIN_AREA:g} m²)")
    n = len(points)
    edges = [(points[i], points[(i + 1) % n]) for i in range(n)]
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue  # the two edges meeting at point 0
            if _cross(*edges[i], *edges[j]):
                raise Refused(f"polygon.points: edge {i} crosses edge {j} (the polygon "
                              "intersects itself)")


def _cross(a, b, c, d) -> bool:
    """Whether segments ab and cd share a point."""
    def side(p, q, r) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    def within(p, q, r) -> bool:
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and \
            min(p[1], q[1]) <= r[1] <= max(p[1], q[1])

    d1, d2, d3, d4 = side(c, d, a), side(c, d, b), side(a, b, c), side(a, b, d)
    if ((d1 > 0) != (d2 > 0) and d1 != 0 and d2 != 0
            and (d3 > 0) != (d4 > 0) and d3 != 0 and d4 != 0):
        return True
    return any(s == 0 and within(p, q, r) for s, p, q, r in (
        (d1, c, d, a), (d2, c, d, b), (d3, a, b, c), (d4, a, b, d)))


def _check_on_map(points: list[tuple[float, float]], grid: dict | None) -> None:
    if grid is None:
        return
    info = grid["info"]
    origin = info["origin"]["position"]
    res = info["resolution"]
    x0, y0 = origin["x"], origin["y"]
    x1, y1 = x0 + info["width"] * res, y0 + info["height"] * res
    for i, (x, y) in enumerate(points):
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            raise Refused(f"polygon.points[{i}]: ({x:g}, {y:g}) is off the map "
                          f"({x0:g}…{x1:g}, {y0:g}…{y1:g})")

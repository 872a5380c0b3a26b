"""Traffic through mutex zones: a robot holds a zone before its path comes near it, waits
(holding none) at a spot just outside when it cannot, and lets it go once it is out again.

**Why it cannot deadlock.** A robot only ever waits at a spot clear of every zone, holding none
(it asks for every zone its path touches before the next clear point in one request, granted
all at once or not at all). So no robot holds a zone while it waits for another: a holder is
always on its way out, every hold ends, and the waiters go in the order they asked (first come,
first served; a later request never overtakes an earlier one that wants a zone it wants). The
one exception is a robot already standing in a zone (it stopped there: paused, failed, or a zone
drawn over it): its request goes first, and it holds that zone while it waits for the others.
A zone drawn over more robots than its capacity says so (the log, the add's reply): each of them
holds it and may leave through it; no other robot goes in until they are all out. A robot gone
offline holds its zone where it was last seen (it still stands there) until it is seen out.

A zone is let go when the robot has gone past it on its path (the ``follow_path`` feedback) and
its reported pose (``/fleet/members``) is :data:`RELEASE` m clear of it — or, for a robot that
stopped in one, as soon as its reported pose is clear.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .tasks import Refused, Stop
from .zones import CAPACITY, Zone

log = logging.getLogger(__name__)

NEAR = 0.5
"""Metres from a zone within which a path point counts as in it: a robot waits at least this
far out (its body is 0.2 m, and it stops within 0.15 m of a spot)."""
RELEASE = 0.25
"""Metres a robot's centre must be out of a zone for its hold to end (its body is out)."""
SPACING = 0.8
"""Metres between two robots' waiting spots: a later waiter stops behind an earlier one."""

PoseOf = Callable[[str], tuple[float, float] | None]


@dataclass(frozen=True)
class Run:
    """A stretch of a path near zones: ``zones`` are held from point ``entry`` (the last clear
    one before) until point ``exit`` (the first clear one after)."""

    zones: frozenset[str]
    entry: int
    exit: int


@dataclass
class Request:
    robot: str
    zones: frozenset[str]
    seq: int
    granted: asyncio.Future = field(default_factory=lambda: asyncio.get_running_loop()
                                    .create_future())


class Traffic:
    """The zones, who holds each (and whether it is past it), who waits, and where."""

    def __init__(self, pose_of: PoseOf, changed: Callable[[], None]):
        self.pose_of, self.changed = pose_of, changed
        self.zones: dict[str, Zone] = {}
        self.holders: dict[str, dict[str, bool]] = {}  # zone → {robot: gone past it}
        self.queue: list[Request] = []
        self.spots: dict[str, tuple[float, float]] = {}  # robot → where it waits
        self._seq = itertools.count()

    # ------------------------------------------------------------------ zones
    def put(self, zone: Zone) -> None:
        self.zones[zone.name] = zone
        self.holders[zone.name] = {}

    def remove(self, name: str) -> None:
        """The zone goes; a request waiting for it no longer does."""
        self.zones.pop(name, None)
        self.holders.pop(name, None)
        for request in self.queue:
            request.zones = request.zones - {name}
        self._grant()

    def near(self, points: np.ndarray) -> list[set[str]]:
        """For each path point, the zones it is within :data:`NEAR` of."""
        out: list[set[str]] = [set() for _ in range(len(points))]
        for zone in self.zones.values():
            for i in np.flatnonzero(zone.distance(points) < NEAR):
                out[i].add(zone.name)
        return out

    def runs(self, points: np.ndarray) -> list[Run]:
        near, runs, i = self.near(points) if len(points) else [], [], 0
        while i < len(near):
            if not near[i]:
                i += 1
                continue
            start, zones = i, set()
            while i < len(near) and near[i]:
                zones |= near[i]
                i += 1
            runs.append(Run(frozenset(zones), max(0, start - 1), min(i, len(near) - 1)))
        return runs

    def check_stop(self, stop: Stop) -> None:
        """A task's stop may not be in a zone (or so near it that a robot there is in it): a
        robot crosses a zone, it does not park in it."""
        here = np.array([[stop.pose.x, stop.pose.y]])
        for zone in self.zones.values():
            if zone.distance(here)[0] < NEAR:
                what = stop.name or f"({stop.pose.x:g}, {stop.pose.y:g})"
                raise Refused(f"{what} is in or within {NEAR:g} m of the mutex zone "
                              f"'{zone.name}': a robot may cross a zone, not stop in it")

    def inside(self, x: float, y: float) -> list[str]:
        """The zones a robot at (x, y) is (partly) in."""
        here = np.array([[x, y]])
        return [n for n, z in self.zones.items() if z.distance(here)[0] < RELEASE]

    # ------------------------------------------------------------------ holding
    async def acquire(self, robot: str, zones: frozenset[str],
                      waiting: Callable[[str], None]) -> bool:
        """Hold ``zones`` (all at once); False when the wait was withdrawn."""
        request = Request(robot, zones, next(self._seq))
        self.queue.append(request)
        self._grant()
        if not request.granted.done():
            waiting(self.why_waiting(request))
            self.changed()
        try:
            return await request.granted
        finally:
            if request in self.queue:
                self.queue.remove(request)

    def withdraw(self, robot: str) -> None:
        """The robot's task stopped (paused, cancelled): it waits no more."""
        for request in [r for r in self.queue if r.robot == robot]:
            self.queue.remove(request)
            if not request.granted.done():
                request.granted.set_result(False)
        self.spots.pop(robot, None)
        self._grant()
        self.changed()

    def passed(self, robot: str, zones: frozenset[str] | None = None) -> None:
        """The robot has gone past ``zones`` (all it holds: its motion ended) on its path."""
        for name, holders in self.holders.items():
            if robot in holders and (zones is None or name in zones):
                holders[robot] = True
        self.moved(robot)

    def let_go(self, name: str, robot: str) -> None:
        """``robot`` no longer holds zone ``name`` (an operator released it)."""
        if self.holders.get(name, {}).pop(robot, None) is not None:
            self._grant()
            self.changed()

    def moved(self, robot: str) -> None:
        """A new pose of ``robot``: the holds it is past and clear of end; a zone it stands
        in without holding it (drawn over it, or after a restart) is its."""
        pose = self.pose_of(robot)
        if pose is None:
            return
        here = set(self.inside(*pose))
        freed = False
        for name, holders in self.holders.items():
            if name in here and robot not in holders:
                holders[robot] = True
                if len(holders) > CAPACITY:
                    log.warning("fleet: %s", self.crowded(name), extra={"ros_node": "/fleet"})
                self.changed()
            elif name not in here and holders.get(robot):
                del holders[robot]
                freed = True
        if freed:
            self._grant()
            self.changed()

    def crowded(self, name: str) -> str:
        """What a zone with more robots standing in it than its capacity says ("" if none)."""
        inside = sorted(self.holders.get(name, {}))
        if len(inside) <= CAPACITY:
            return ""
        return (f"robots {', '.join(inside)} stand in zone {name}, more than its capacity of "
                f"{CAPACITY}: no other robot goes in until they are out")

    def _grant(self) -> None:
        """First come, first served; a robot already in one of its zones goes first."""
        order = sorted(self.queue, key=lambda r: (not self._holds_any(r), r.seq))
        wanted: set[str] = set()  # zones an earlier waiter asked for
        for request in order:
            if self._blocked(request) or request.zones & wanted:
                wanted |= request.zones
                continue
            for name in request.zones:
                self.holders[name][request.robot] = False
            self.queue.remove(request)
            self.spots.pop(request.robot, None)
            if not request.granted.done():
                request.granted.set_result(True)
            self.changed()

    def _blocked(self, request: Request) -> bool:
        """Another robot holds a zone the request asks for; one the robot holds itself (it
        stands in it, perhaps with others: a zone drawn over them) it may leave through."""
        return any(held and request.robot not in held
                   for held in (self.holders.get(z, {}) for z in request.zones))

    def _holds_any(self, request: Request) -> bool:
        return any(request.robot in self.holders.get(z, {}) for z in request.zones)

    def waiting_for(self, robot: str) -> str:
        """What ``robot`` waits for, as :meth:`why_waiting` says it ('' when it waits for no
        zone)."""
        return next((self.why_waiting(r) for r in self.queue
                     if r.robot == robot and not r.granted.done()), "")

    def why_waiting(self, request: Request) -> str:
        names = ", ".join(sorted(request.zones))
        held = sorted({h for z in request.zones for h in self.holders.get(z, {})}
                      - {request.robot})
        why = f"held by {', '.join(held)}" if held else "others asked first"
        return f"waiting for zone {names} ({why})"

    def spot(self, robot: str, points: np.ndarray, low: int, entry: int) -> int:
        """Where ``robot`` stops before a run: its entry point, or further back along its
        path (not before ``low``) when another robot waits within :data:`SPACING` of it."""
        others = [xy for r, xy in self.spots.items() if r != robot]
        chosen = low
        for i in range(entry, low - 1, -1):
            x, y = points[i]
            if all((x - ox) ** 2 + (y - oy) ** 2 >= SPACING ** 2 for ox, oy in others):
                chosen = i
                break
        self.spots[robot] = (float(points[chosen][0]), float(points[chosen][1]))
        return chosen

    # ------------------------------------------------------------------ the topic
    def msg(self) -> dict:
        waiting: dict[str, list[str]] = {}
        for request in sorted(self.queue, key=lambda r: r.seq):
            for name in request.zones:
                waiting.setdefault(name, []).append(request.robot)
        return {"zones": [{
            "name": z.name, "kind": z.kind, "capacity": CAPACITY,
            "polygon": {"points": [{"x": x, "y": y, "z": 0.0} for x, y in z.points]},
            "holders": sorted(self.holders.get(z.name, {})),
            "waiting": waiting.get(z.name, [])} for z in self.zones.values()]}

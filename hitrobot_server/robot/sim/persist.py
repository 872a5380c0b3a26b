"""The simulated robot's memory across restarts: its map, lines, home, pose and battery.

A real Slamware robot keeps its map, virtual walls and tracks, home and (roughly) its pose
across reboots; the simulator does the same through the state store. Sections:
``sim/map`` (bytes: our composite-map container, explore map only), ``sim/lines`` (walls,
tracks, home) and ``sim/robot`` (true and believed pose, battery, localization on/off).
Requests that change the robot are written through at once (the backend awaits the write
before it answers); motion, the battery and mapping are sampled as the robot runs.
"""

from __future__ import annotations

import asyncio
import logging
import math

from ...state import StateStore
from .simulator import Simulator

log = logging.getLogger(__name__)

MAP, LINES, ROBOT = "sim/map", "sim/lines", "sim/robot"
MAP_EVERY = 2.0
"""Seconds between map samples while mapping (a burst of map changes is one write)."""
MOVED = 0.01
TURNED = math.radians(0.5)
CHARGED = 0.1


class SimMemory:
    """Restores a simulator from the store and writes its changes back."""

    def __init__(self, store: StateStore) -> None:
        self.store = store
        self._robot: dict | None = None
        self._lines: dict | None = None
        self._map_revision: int | None = None
        self._map_due = 0.0

    def restore(self, sim: Simulator) -> list[str]:
        """Install what the store has; what was restored, as phrases for the start-up log.
        A section the simulator refuses is reported to the store and skipped."""
        done: list[str] = []
        for key, apply in ((MAP, sim.map.restore_map), (LINES, sim.map.restore_lines),
                           (ROBOT, sim.restore_robot)):
            value = self.store.get(key)
            if value is None:
                continue
            try:
                apply(value)
            except (ValueError, TypeError) as exc:
                self.store.reject(key, str(exc))
                continue
            if key == LINES:
                done.append(f"{_count(value['walls'], 'wall')}, "
                            f"{_count(value['tracks'], 'track')}"
                            + (", home" if value["home"] is not None else ""))
            elif key == ROBOT:
                x, y, _ = value["believed"]
                done.append(f"robot pose ({x:.1f}, {y:.1f}), battery {value['battery']:.0f}%")
            else:
                done.append("the robot's map")
        self._robot, self._lines = sim.saved_robot(), sim.map.saved_lines()
        self._map_revision = sim.map.map_revision
        return done

    def take_back_lines(self, sim: Simulator, lines: dict | None) -> bool:
        """A change that could not be written: the walls, tracks and home as they were before
        it (True when it had changed them). The next sample writes them again."""
        if lines is None or lines == sim.map.saved_lines():
            return False
        sim.map.restore_lines(lines)
        self._lines = None
        return True

    def sync(self, sim: Simulator, now: float, urgent: bool = False) -> asyncio.Future | None:
        """Put what changed since the last call; the future of the last put, if any.
        ``urgent``: a request changed the robot, so the map is taken without waiting."""
        last = None
        lines = sim.map.saved_lines()
        if lines != self._lines:
            self._lines = lines
            last = self.store.put(LINES, lines)
        if sim.map.map_revision != self._map_revision and (urgent or now >= self._map_due):
            self._map_revision = sim.map.map_revision
            self._map_due = now + MAP_EVERY
            last = self.store.put(MAP, sim.map.saved_map())
        robot = sim.saved_robot()
        if self._robot is None or _robot_changed(self._robot, robot):
            self._robot = robot
            last = self.store.put(ROBOT, robot)
        return last


def _count(items: list, word: str) -> str:
    return f"{len(items)} {word}{'' if len(items) == 1 else 's'}"


def _robot_changed(old: dict, new: dict) -> bool:
    (x0, y0, a0), (x1, y1, a1) = old["believed"], new["believed"]
    (tx0, ty0, _), (tx1, ty1, _) = old["pose"], new["pose"]
    return (math.hypot(x1 - x0, y1 - y0) > MOVED or math.hypot(tx1 - tx0, ty1 - ty0) > MOVED
            or abs(math.remainder(a1 - a0, math.tau)) > TURNED
            or abs(new["battery"] - old["battery"]) >= CHARGED
            or new["localization"] != old["localization"])

"""A dispatch request (``hitrobot_msgs/Dispatch``, also what a schedule keeps) read into a task's
kind and stops, every number checked before anything is accepted."""

from __future__ import annotations

import math

from ...bus.core import Bus
from ...bus.topics import RequestRejected
from ..ground import messages as m
from ..ground.placement import cells_of, placement_problem
from ..ground.pois import find_poi
from .tasks import (
    CHARGE,
    GOTO,
    KINDS,
    MAX_DWELL,
    MAX_LAPS,
    MAX_STOPS,
    PATROL,
    Refused,
    Stop,
    checked_pose,
)

SITE_LIMIT = 10_000.0
"""Metres from the map origin beyond which a target is refused at once (off any site's map)."""


async def read_stops(bus: Bus, request: dict) -> tuple[str, list[Stop], int]:
    """The request's kind, stops and laps; :class:`Refused` naming the field that is wrong."""
    kind = request.get("kind") or GOTO
    if kind not in KINDS or kind == CHARGE:
        raise Refused(f"kind: '{kind}' is not one of goto, sequence, patrol (a charge is the "
                      "fleet's own)")
    laps = int(request.get("laps") or 1) if kind == PATROL else 1
    if not 1 <= laps <= MAX_LAPS:
        raise Refused(f"laps: {laps} is not between 1 and {MAX_LAPS}")
    if kind == GOTO:
        poi = request.get("poi", "")
        if poi:
            return kind, [Stop(poi, await _poi_pose(bus, poi))], laps
        try:
            pose = m.pose2d_of(request["pose"], "pose")
        except RequestRejected as exc:
            raise Refused(str(exc)) from None
        return kind, [Stop("", checked_pose(pose, "pose", SITE_LIMIT))], laps
    names = list(request.get("pois") or [])
    dwell = [float(d) for d in request.get("dwell") or []]
    if not names or len(names) > MAX_STOPS:
        raise Refused(f"pois: a {kind} needs 1 to {MAX_STOPS} POIs")
    if kind == PATROL and len(names) < 2:
        raise Refused("pois: a patrol route needs at least 2 POIs")
    if len(dwell) > len(names) or not all(math.isfinite(d) and 0 <= d <= MAX_DWELL
                                          for d in dwell):
        raise Refused(f"dwell: one time (0–{MAX_DWELL:g} s) per POI at most")
    dwell += [0.0] * (len(names) - len(dwell))
    return kind, [Stop(n, await _poi_pose(bus, n), d) for n, d in zip(names, dwell,
                                                                       strict=True)], laps


async def _poi_pose(bus: Bus, name: str):
    try:
        poi = await find_poi(bus, name)
    except Exception as exc:
        raise Refused(f"the POIs cannot be read: {exc}") from None
    if poi is None:
        raise Refused(f"unknown POI '{name}'")
    return m.pose2d(poi["pose"])


def check_placed(grid: dict | None, stop: Stop) -> None:
    """Refuse a stop where the robot cannot stand on the site map (``/map``): off it, on an
    unknown cell, on an obstacle or nearer one than the robot's clearance (the POIs' rule,
    ground/placement.py). No robot could stop there, and a search that fails explores the whole
    map."""
    x, y = stop.pose.x, stop.pose.y
    problem = placement_problem(cells_of(grid), x, y, where=stop.name or f"({x:g}, {y:g})")
    if problem:
        raise Refused(problem)

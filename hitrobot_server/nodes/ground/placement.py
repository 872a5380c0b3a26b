"""Where the robot may be sent (pure rule, one reader of the site map): a POI, a goal, a patrol
waypoint or a fleet target must not stand on an obstacle or nearer one than the robot's
clearance. A POI placed beside a table used to be accepted and fail only after the drive there
("inside an obstacle"), and so did a goal or a waypoint sent by an API client: each is now
refused before the robot moves, with the reason.

The clearance is the robot's footprint radius plus the planner's safety margin: 0.20 m + 0.05 m,
the defaults of the simulated robot (``robot/sim/kinematics.py`` ``DriveLimits.radius`` and
``robot/planning/costmap.py`` ``CostmapConfig.safety_margin``, kept equal by a test), whose planner
refuses a goal nearer an obstacle than that. The Slamware robot does not tell its footprint over
its API, so the same figure stands for it. The console (``web/placement.js``) warns with the
same rule and figure while the operator places a POI, a goal or a waypoint.

A place that is kept (a POI, a fleet target) must also be on known floor of the map
(``known=True``); a goal or a waypoint may lie in unexplored space or beyond the map's edge,
where the robot's planner drives (it explores), so only obstacles refuse it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ...bus.topics import MemoKey, Message
from .names import MAP_TOPIC

ROBOT_RADIUS = 0.20
SAFETY_MARGIN = 0.05
CLEARANCE = ROBOT_RADIUS + SAFETY_MARGIN
OCCUPIED_FROM = 65
"""Occupancy values from this up are obstacles (ROS map_server's occupied_thresh, 0.65)."""
UNKNOWN = -1


class Cells(Protocol):
    """An occupancy grid as ROS has it: ``data[row, col]`` (-1 unknown, 0..100), row 0 at the
    minimum y, ``(origin_x, origin_y)`` the lower-left corner of cell (0, 0)."""

    origin_x: float
    origin_y: float
    resolution: float
    data: np.ndarray


@dataclass(frozen=True, slots=True, eq=False)
class MapCells:
    """A ``nav_msgs/OccupancyGrid``'s cells, as the placement rule reads them."""

    origin_x: float
    origin_y: float
    resolution: float
    data: np.ndarray


def cells_of(msg: dict | None) -> MapCells | None:
    """The cells of a ``nav_msgs/OccupancyGrid`` dict; None when there is none or it does not
    hold together (nothing to judge by)."""
    if msg is None:
        return None
    try:
        info = msg["info"]
        width, height, res = int(info["width"]), int(info["height"]), float(info["resolution"])
        origin = info["origin"]["position"]
        x, y = float(origin["x"]), float(origin["y"])
        data = np.asarray(msg["data"])
        if not (width > 0 and height > 0 and res > 0 and math.isfinite(res)
                and math.isfinite(x) and math.isfinite(y) and data.size == width * height):
            return None
        return MapCells(x, y, res, data.astype(np.int8, copy=False).reshape(height, width))
    except (KeyError, TypeError, ValueError):
        return None


CELLS: MemoKey[MapCells | None] = MemoKey("placement cells",
                                          lambda message, _variant: cells_of(message.msg))
"""A ``/map`` message's cells, made once for every node that checks a place on it."""


def site_cells(bus) -> MapCells | None:
    """The latest composed ``/map`` on ``bus`` (the site's, a site-wide name: every robot's view
    reads the same), or None while there is none."""
    topic = bus.topic(MAP_TOPIC)
    last: Message | None = topic.last if topic is not None else None
    return CELLS.get(last) if last is not None else None


def target_problem(bus, what: str, x: float, y: float) -> str | None:
    """Why ``what`` (a goal, a waypoint) at (x, y) cannot be sent on the site map, naming it:
    ``"goal (3.20, 1.10) is on an obstacle"``; None when it can (or there is no map)."""
    problem = placement_problem(site_cells(bus), x, y, known=False)
    return f"{what} {problem}" if problem else None


def placement_problem(grid: Cells | None, x: float, y: float, clearance: float = CLEARANCE,
                      *, known: bool = True, where: str | None = None) -> str | None:
    """Why a place at (x, y) is refused on ``grid``, or None when it is not (or when there is
    no map yet to judge by). ``known``: it must be on a known cell of the map too. ``where``:
    how the place is named (its coordinates by default)."""
    if grid is None:
        return None
    res = grid.resolution
    height, width = grid.data.shape
    col = math.floor((x - grid.origin_x) / res)
    row = math.floor((y - grid.origin_y) / res)
    where = where or f"({x:.2f}, {y:.2f})"
    if 0 <= row < height and 0 <= col < width:
        value = int(grid.data[row, col])
        if value == UNKNOWN and known:
            return f"{where} is on an unknown cell of the map"
        if value >= OCCUPIED_FROM:
            return f"{where} is on an obstacle"
    elif known:
        return f"{where} is off the map"
    near = nearest_obstacle(grid, x, y, clearance)
    if near is not None:
        return (f"{where} is {near:.2f} m from an obstacle, nearer than the robot's clearance "
                f"of {clearance:.2f} m (radius {ROBOT_RADIUS:.2f} m + margin "
                f"{SAFETY_MARGIN:.2f} m)")
    return None


def nearest_obstacle(grid: Cells, x: float, y: float, within: float) -> float | None:
    """The distance from (x, y) to the nearest occupied cell's edge if under ``within``."""
    res = grid.resolution
    height, width = grid.data.shape
    reach = math.ceil(within / res) + 1
    col = math.floor((x - grid.origin_x) / res)
    row = math.floor((y - grid.origin_y) / res)
    r0, r1 = max(row - reach, 0), min(row + reach + 1, height)
    c0, c1 = max(col - reach, 0), min(col + reach + 1, width)
    if r0 >= r1 or c0 >= c1:
        return None
    rows, cols = np.nonzero(grid.data[r0:r1, c0:c1] >= OCCUPIED_FROM)
    if rows.size == 0:
        return None
    cx = grid.origin_x + (cols + c0 + 0.5) * res
    cy = grid.origin_y + (rows + r0 + 0.5) * res
    dx = np.maximum(np.abs(cx - x) - res / 2, 0.0)
    dy = np.maximum(np.abs(cy - y) - res / 2, 0.0)
    nearest = float(np.min(np.hypot(dx, dy)))
    return nearest if nearest < within else None

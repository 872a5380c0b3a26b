"""Where a POI may stand (pure): on a known free cell of the composed ``/map``, at least the
robot's clearance away from every occupied cell. A POI placed beside a table used to be
accepted and fail only after the drive there ("inside an obstacle"); the map manager now says
so when it is placed.

The clearance is the robot's footprint radius plus the planner's safety margin: 0.20 m + 0.05 m,
the defaults of the simulated robot (``robot/sim/kinematics.py`` ``DriveLimits.radius`` and
``robot/planning/costmap.py`` ``CostmapConfig.safety_margin``, kept equal by a test), whose planner
refuses a goal nearer an obstacle than that. The Slamware robot does not tell its footprint over
its API, so the same figure stands for it. The console (``web/placement.js``) warns with the
same rule and figure while the operator places a POI.
"""

from __future__ import annotations

import math

import numpy as np

from .layers import UNKNOWN, Grid

ROBOT_RADIUS = 0.20
SAFETY_MARGIN = 0.05
CLEARANCE = ROBOT_RADIUS + SAFETY_MARGIN
OCCUPIED_FROM = 65
"""Occupancy values from this up are obstacles (ROS map_server's occupied_thresh, 0.65)."""


def placement_problem(grid: Grid | None, x: float, y: float,
                      clearance: float = CLEARANCE) -> str | None:
    """Why a POI cannot stand at (x, y) on ``grid``, or None when it can (or when there is no
    map yet to judge by)."""
    if grid is None:
        return None
    res = grid.resolution
    col = math.floor((x - grid.origin_x) / res)
    row = math.floor((y - grid.origin_y) / res)
    where = f"({x:.2f}, {y:.2f})"
    if not (0 <= row < grid.height and 0 <= col < grid.width):
        return f"{where} is outside the map"
    value = int(grid.data[row, col])
    if value == UNKNOWN:
        return f"{where} is on an unknown cell of the map"
    if value >= OCCUPIED_FROM:
        return f"{where} is on an obstacle"
    near = nearest_obstacle(grid, x, y, clearance)
    if near is not None:
        return (f"{where} is {near:.2f} m from an obstacle, nearer than the robot's clearance "
                f"of {clearance:.2f} m (radius {ROBOT_RADIUS:.2f} m + margin "
                f"{SAFETY_MARGIN:.2f} m)")
    return None


def nearest_obstacle(grid: Grid, x: float, y: float, within: float) -> float | None:
    """The distance from (x, y) to the nearest occupied cell's edge if under ``within``."""
    res = grid.resolution
    reach = math.ceil(within / res) + 1
    col = math.floor((x - grid.origin_x) / res)
    row = math.floor((y - grid.origin_y) / res)
    r0, r1 = max(row - reach, 0), min(row + reach + 1, grid.height)
    c0, c1 = max(col - reach, 0), min(col + reach + 1, grid.width)
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

"""Where a POI may stand (nodes/ground/placement.py), checked directly on small grids:
a known free cell at least the robot's clearance from every obstacle."""

from __future__ import annotations

import numpy as np
import pytest

from hitrobot_server.nodes.ground.placement import (
    CLEARANCE,
    ROBOT_RADIUS,
    SAFETY_MARGIN,
    placement_problem,
)
from hitrobot_server.nodes.map_manager.layers import Grid
from hitrobot_server.robot.planning.costmap import CostmapConfig
from hitrobot_server.robot.sim.kinematics import DriveLimits
from tests.nodes.map_manager.util import MM, poi, request, start

RES = 0.05


def room() -> Grid:
    """4 m x 2 m at 5 cm, origin (-1, -1): free, an obstacle column at x in [1.0, 1.05),
    an unknown strip at y >= 0.5."""
    data = np.zeros((40, 80), dtype=np.int8)
    data[:, 40] = 100
    data[30:, :] = -1
    return Grid(-1.0, -1.0, RES, data)


def test_the_clearance_is_the_simulated_robots():
    assert DriveLimits().radius == ROBOT_RADIUS
    assert CostmapConfig().safety_margin == SAFETY_MARGIN
    assert pytest.approx(0.25) == CLEARANCE


def test_a_free_cell_far_from_obstacles_is_accepted():
    assert placement_problem(room(), 0.0, 0.0) is None
    assert placement_problem(None, 100.0, 100.0) is None  # no map yet: nothing to judge by


@pytest.mark.parametrize(("x", "y", "words"), [
    (1.02, 0.0, "on an obstacle"),
    (0.0, 0.8, "unknown cell"),
    (5.0, 0.0, "off the map"),
    (0.0, -1.5, "off the map"),
])
def test_obstacles_unknown_and_outside_are_refused(x, y, words):
    problem = placement_problem(room(), x, y)
    assert problem is not None and words in problem


def test_nearer_an_obstacle_than_the_clearance_is_refused_with_the_figures():
    # the obstacle's near edge is at x = 1.0
    near = placement_problem(room(), 0.85, 0.0)
    assert near is not None
    assert "0.15 m from an obstacle" in near and "0.25 m" in near and "radius 0.20 m" in near
    assert placement_problem(room(), 0.7, 0.0) is None  # 0.30 m away
    assert placement_problem(room(), 1.40, 0.0) is None  # 0.35 m on the far side
    assert placement_problem(room(), 1.20, 0.0) is not None  # 0.15 m on the far side


async def test_the_map_manager_refuses_a_poi_beside_an_obstacle_with_the_reason(make_server,
                                                                              tmp_path):
    """Over the bus: refused with the reason, nothing stored; a free spot is accepted; moving a
    POI is checked, renaming it in place is not."""
    _server, w = await start(make_server, tmp_path)
    poi_t = "map_messages/PointOfInterest"
    refused = await request(w, f"{MM}/add_poi", poi_t, poi("table", 11.0, 2.0), "near")
    assert refused["level"] == "error", refused
    assert "from an obstacle, nearer than the robot's clearance of 0.25 m" in refused["msg"]
    wall = await request(w, f"{MM}/add_poi", poi_t, poi("wall", 0.0, 0.0), "wall")
    assert wall["level"] == "error" and "on an obstacle" in wall["msg"], wall
    ok = await request(w, f"{MM}/add_poi", poi_t, poi("desk", 11.5, 2.0), "ok")
    assert ok["level"] == "info", ok
    moved = await request(w, f"{MM}/modify_poi", "map_messages/ModifyPOI",
                          {"poi": poi("desk", 11.0, 2.0), "old_name": "desk"}, "move")
    assert moved["level"] == "error" and "nearer than" in moved["msg"], moved
    renamed = await request(w, f"{MM}/modify_poi", "map_messages/ModifyPOI",
                            {"poi": poi("desk 2", 11.5, 2.0), "old_name": "desk"}, "rename")
    assert renamed["level"] == "info", renamed
    reply = await w.call(f"{MM}/get_pois")
    assert [(p["name"], p["pose"]["position"]["x"]) for p in reply["values"]["poi_list"]["pois"]] \
        == [("desk 2", 11.5)]

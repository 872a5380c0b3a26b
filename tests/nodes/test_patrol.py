"""Patrol routes: the pure parts, then a route saved, listed, loaded and resumed from the
nearest waypoint on a real server with the simulated robot."""

from __future__ import annotations

import math

import pytest

from hitrobot_server.nodes.patrol import (
    RouteError,
    Waypoint,
    decode_route,
    encode_route,
    frame_ok,
    nearest,
    waypoints_of,
)
from tests.nodes.map_manager.util import current, start

FRAMES = frozenset({"map", "floor1"})


def wp(x: float, y: float, frame: str = "map") -> dict:
    return {"frame": frame, "x": x, "y": y, "z": 0.0, "use_z": False}


def test_frames_waypoints_and_route_files():
    for frame in ("map", "/map", "floor1", "odom", "/odom"):
        frame_ok(frame, FRAMES)
    with pytest.raises(RouteError, match="no GPS receiver"):
        frame_ok("gps", FRAMES)
    with pytest.raises(RouteError, match="neither the loaded map nor odom"):
        frame_ok("floor2", FRAMES)
    with pytest.raises(RouteError, match=r"waypoints\[1\]: field 'waypoints\[1\].x'"):
        waypoints_of([wp(1, 2), wp(float("nan"), 2)], FRAMES)
    with pytest.raises(RouteError, match="at most 256"):
        waypoints_of([wp(0, 0)] * 257, FRAMES)
    route = [Waypoint("floor1", 1.25, -3.5, 0.1, True), Waypoint("odom", 1e-9, 7.0)]
    assert decode_route(encode_route(route), FRAMES) == route
    with pytest.raises(Exception, match="version 1"):
        decode_route(b"waypoints: []", FRAMES)
    assert nearest([Waypoint("map", 0, 0), Waypoint("map", 5, 5), Waypoint("map", 4, 4)],
                   4.4, 4.4) == 2


ROUTE = [wp(2.5, 8.0), wp(7.0, 8.0), wp(9.0, 7.5)]


def reached(w, index: int, after: int = 0) -> bool:
    return any(m["message"] == f"reached waypoint {index}"
               for _t, m in w.messages["/planning/patrol_state"][after:])


async def test_route_saved_loaded_and_resumed_from_nearest(make_server, tmp_path):
    maps = tmp_path / "maps"
    _server, w = await start(make_server, maps)
    await w.subscribe("/planning/patrol_state", "hitrobot_msgs/PatrolState")
    await w.until(lambda: w.latest("/planning/patrol_state"), 5, "patrol state")
    assert (await w.call("/planning/resume_patrol"))["values"] == {
        "success": False, "message": "No waypoints loaded", "waypoint_index": 0}
    assert (await w.call("/planning/set_waypoints", {"waypoints": ROUTE[:2]}))["values"][
        "success"]
    reply = (await w.call("/planning/append_waypoint", {"waypoint": ROUTE[2]}))["values"]
    assert reply == {"success": True, "message": "waypoint 2 added", "waypoint_index": 2}
    assert (await w.call("/planning/save_waypoints_file", {"name": "rounds"}))["values"] == {
        "success": True, "message": "Waypoints saved to: rounds"}
    assert (tmp_path / "routes" / "rounds.yaml").is_file()  # next to the map store
    assert (await w.call("/planning/list_waypoints_files", {"directory": ""}))["values"] == {
        "success": True, "message": "Found 1 files", "files": ["rounds"]}
    assert (await w.call("/planning/clear_waypoints"))["values"]["success"]
    assert w.latest("/planning/patrol_state")["waypoints"] == []
    assert (await w.call("/planning/load_waypoints_file", {"name": "nothing"}))["values"] == {
        "success": False, "message": "File not found: nothing"}
    assert (await w.call("/planning/load_waypoints_file", {"name": "rounds"}))["values"] == {
        "success": True, "message": "Waypoints loaded from: rounds"}
    state = w.latest("/planning/patrol_state")
    assert state["waypoints"] == ROUTE and state["route"] == "rounds" and not state["active"]

    # the robot starts at (5, 8): waypoint 1 (7, 8) is the nearest
    seen = len(w.messages["/planning/patrol_state"])
    assert (await w.call("/planning/resume_patrol"))["values"] == {
        "success": True, "message": "Resuming from waypoint 1", "waypoint_index": 1}
    visits = []
    for index in (1, 2, 0, 1):
        await w.until(lambda i=index, s=seen: reached(w, i, s), 40, f"waypoint {index} reached")
        seen = next(k for k, (_t, m) in enumerate(w.messages["/planning/patrol_state"])
                    if k >= seen and m["message"] == f"reached waypoint {index}") + 1
        x, y, _ = current(w)
        visits.append(index)
        target = ROUTE[index]
        assert math.hypot(x - target["x"], y - target["y"]) < 0.5, (index, x, y)
    assert visits == [1, 2, 0, 1]
    assert w.latest("/planning/patrol_state")["laps"] >= 1
    assert (await w.call("/planning/stop_patrol"))["values"]["success"]
    state = await w.until(lambda: not (s := w.latest("/planning/patrol_state"))["active"]
                          and s, 5, "the patrol stopped")
    assert state["target_index"] == -1
    await w.close()


async def test_bad_route_file_names_touch_nothing(make_server, tmp_path):
    maps = tmp_path / "maps"
    _server, w = await start(make_server, maps)
    await w.call("/planning/set_waypoints", {"waypoints": ROUTE[:1]})
    before = sorted(str(p) for p in tmp_path.rglob("*"))
    for name, needle in [("", "must not be empty"), ("../../escape", "path separators"),
                         (str(tmp_path / "abs"), "absolute path"), ("r" * 65, "too long"),
                         (".hidden", "must not start with '.'"), ("a\nb", "control characters")]:
        for service in ("save_waypoints_file", "load_waypoints_file"):
            reply = (await w.call(f"/planning/{service}", {"name": name}))["values"]
            assert not reply["success"] and needle in reply["message"], (service, name, reply)
        reply = (await w.call("/save_graph_file", {"name": name, "nodes": [], "edges": []}))
        assert not reply["values"]["success"] and needle in reply["values"]["message"]
        reply = (await w.call("/load_graph_file", {"name": name}))["values"]
        assert not reply["success"] and needle in reply["message"]
    assert sorted(str(p) for p in tmp_path.rglob("*")) == before
    reply = (await w.call("/planning/list_waypoints_files", {"directory": "/"}))["values"]
    assert not reply["success"] and reply["files"] == []
    await w.close()

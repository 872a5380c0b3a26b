"""list_map_files, load_laser_map and set_map over the map manager's store, and a map's
default graph and route, on a real server with the simulated robot."""

from __future__ import annotations

import pytest

from hitrobot_server.nodes.ground.namedfiles import (
    FileError,
    NamedFiles,
    check_name,
    is_default_dir,
)
from tests.nodes.map_manager.util import MM, request, start


def test_named_files_refuse_bad_names(tmp_path):
    files = NamedFiles(tmp_path / "routes")
    for bad, needle in [("", "empty"), ("../evil", "path separators"), ("/etc/passwd", "absolute"),
                        ("..", "must not start with '.'"), ("x" * 65, "too long"),
                        ("a\x00b", "control characters"), ("C:\\x", "absolute")]:
        with pytest.raises(FileError, match=needle) as info:
            files.path(bad)
        assert "file name" in str(info.value) or "empty" in str(info.value)
    assert files.names() == []
    files.write("route 1", b"x")
    assert files.names() == ["route 1"] and files.read("route 1") == b"x"
    assert [p.name for p in (tmp_path / "routes").iterdir()] == ["route 1.yaml"]
    assert check_name("ok-name.v2") == "ok-name.v2"
    assert is_default_dir(tmp_path, "") and is_default_dir(tmp_path, str(tmp_path))
    assert not is_default_dir(tmp_path, "/etc")


def wp(frame: str, x: float, y: float) -> dict:
    return {"frame": frame, "x": x, "y": y, "z": 0.0, "use_z": False}


async def test_map_files_and_their_default_graph_and_route(make_server, tmp_path):
    maps = tmp_path / "maps"
    _server, w = await start(make_server, maps)
    await w.subscribe("/planning/patrol_state", "hitrobot_msgs/PatrolState")
    await w.subscribe("/graph/current", "hitrobot_msgs/Graph")
    for name in ("floor1", "floor2"):
        status = await request(w, f"{MM}/save_map", "map_messages/SaveMap", {"filename": name},
                               f"save-{name}", timeout=30)
        assert status["level"] == "info", status
    reply = (await w.call("/list_map_files", {"directory": ""}))["values"]
    assert reply == {"success": True, "message": "Found 2 files", "files": ["floor1", "floor2"]}
    reply = (await w.call("/list_map_files", {"directory": "/etc"}))["values"]
    assert not reply["success"] and "only the default directory" in reply["message"]
    assert (await w.call("/load_laser_map", {"name": "nowhere"}))["values"] == {
        "success": False, "message": "Map not found"}
    reply = (await w.call("/load_laser_map", {"name": "../maps"}))["values"]
    assert not reply["success"] and "path separators" in reply["message"]

    assert (await w.call("/load_laser_map", {"name": "floor1"}, timeout=30))["values"] == {
        "success": True, "message": "Map loaded."}
    # the map's name is now the waypoint frame and the map odometry's topic component
    await w.subscribe("/floor1/robot_0/Odometry", "nav_msgs/Odometry")
    await w.until(lambda: w.latest("/floor1/robot_0/Odometry"), 5, "map odometry of floor1")
    route = [wp("floor1", 4.0, 8.0), wp("odom", 6.0, 8.0)]
    assert (await w.call("/planning/set_waypoints", {"waypoints": route}))["values"]["success"]
    reply = (await w.call("/planning/save_waypoints_file", {"name": "morning"}))["values"]
    assert reply == {"success": True, "message": "Waypoints saved to: morning"}
    nodes = [{"id": 1, "x": 4.0, "y": 8.0, "z": 0.0}, {"id": 2, "x": 6.0, "y": 8.0, "z": 0.0}]
    edges = [{"from_node": 1, "to_node": 2, "cost": 0.0}]
    reply = (await w.call("/save_graph_file", {"name": "g", "nodes": nodes, "edges": edges}))
    assert reply["values"] == {"success": True, "message": "Graph saved to: g"}
    assert {"graph.yaml", "route.yaml"} <= {p.name for p in (maps / "floor1").iterdir()}
    assert not (maps / "floor2" / "route.yaml").exists()

    # set_map: the initial pose in the loaded map ("Map saved." is the seed's text)
    pose = {"position": {"x": 5.2, "y": 8.1, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
    reply = (await w.call("/set_map", {"name": "floor1", "initial_pose": pose}))["values"]
    assert reply == {"success": True, "message": "Map saved."}
    reply = (await w.call("/set_map", {"name": "floor2", "initial_pose": pose}))["values"]
    assert not reply["success"] and "load_laser_map first" in reply["message"]

    # another map loaded through the map manager itself is noticed too
    await w.call("/planning/clear_waypoints")
    status = await request(w, f"{MM}/load_map", "map_messages/SaveMap", {"filename": "floor2"},
                           "load-floor2", timeout=30)
    assert status["level"] == "info", status
    await w.subscribe("/floor2/robot_0/Odometry", "nav_msgs/Odometry")
    await w.until(lambda: w.latest("/floor2/robot_0/Odometry"), 5, "map odometry of floor2")
    await w.call("/save_graph_file", {"name": "other", "nodes": nodes[:1], "edges": []})
    assert (maps / "floor2" / "graph.yaml").is_file()  # floor2's default graph now
    assert len(w.latest("/graph/current")["nodes"]) == 1
    # a waypoint in floor1's frame is refused now; gps always
    reply = (await w.call("/planning/append_waypoint", {"waypoint": wp("floor1", 1, 1)}))
    assert not reply["values"]["success"] and "neither the loaded map" in reply["values"]["message"]
    reply = (await w.call("/planning/append_waypoint", {"waypoint": wp("gps", 52.1, 4.3)}))
    assert not reply["values"]["success"] and "no GPS" in reply["values"]["message"]

    # loading floor1 again brings back its graph and route
    assert (await w.call("/load_laser_map", {"name": "floor1"}, timeout=30))["values"][
        "message"] == "Map loaded."
    state = await w.until(lambda: (s := w.latest("/planning/patrol_state"))["waypoints"]
                          and s, 5, "the default route")
    assert state["waypoints"] == route and state["route"] == "route"
    graph = w.latest("/graph/current")
    assert graph["nodes"] == nodes and graph["edges"] == edges
    await w.close()

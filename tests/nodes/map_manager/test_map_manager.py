"""``/map_manager`` on a real server with the simulated robot, driven by real clients."""

from __future__ import annotations

import asyncio
import io
import math
import os

import numpy as np
import pytest
import yaml
from PIL import Image

from tests.helpers import Watcher, WsClient
from tests.nodes.map_manager.util import (
    BLOCKED,
    MASKING_LAYER,
    MM,
    NOT_MASKED,
    NS,
    OBSTACLE,
    SICK_LAYER,
    SLAM_LAYER,
    cell,
    modify_map,
    poi,
    rect,
    request,
    start,
)
from tests.witness import RoundTrips

POI_T = "map_messages/PointOfInterest"
SAVE_T = "map_messages/SaveMap"


def names(w: Watcher) -> list[str]:
    return [p["name"] for p in w.latest(f"{MM}/pois")["pois"]]


async def test_poi_crud_and_refusals(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path)
    assert names(w) == []
    for i, (name, x) in enumerate((("dock", 3.5), ("desk", 10.0), ("door", 9.5))):
        got = await request(w, f"{MM}/add_poi", POI_T, poi(name, x, 1.0), f"add{i}")
        assert got["level"] != "error", got
    await w.until(lambda: names(w) == ["dock", "desk", "door"], 5, "three POIs")
    refused = {
        "dup": (f"{MM}/add_poi", POI_T, poi("desk", 0.0, 0.0), "already exists"),
        "type": (f"{MM}/add_poi", POI_T, poi("odd", 0.0, 0.0, kind=500), "type"),
        "empty": (f"{MM}/add_poi", POI_T, poi("", 0.0, 0.0), "empty"),
        "mod-missing": (f"{MM}/modify_poi", "map_messages/ModifyPOI",
                        {"poi": poi("x", 0.0, 0.0), "old_name": "nope"}, "no POI named 'nope'"),
        "mod-clash": (f"{MM}/modify_poi", "map_messages/ModifyPOI",
                      {"poi": poi("dock", 0.0, 0.0), "old_name": "desk"}, "already exists"),
        "del-missing": (f"{MM}/delete_poi", "map_messages/DeletePointOfInterest",
                        {"name": "nope"}, "no POI named 'nope'"),
    }
    count = len(w.messages[f"{MM}/pois"])
    for op_id, (topic, type_name, msg, needle) in refused.items():
        status = await request(w, topic, type_name, msg, op_id)
        assert status["level"] == "error" and needle in status["msg"], status
    await asyncio.sleep(0.2)
    assert len(w.messages[f"{MM}/pois"]) == count  # nothing changed, nothing republished
    await request(w, f"{MM}/modify_poi", "map_messages/ModifyPOI",
                  {"poi": poi("desk 2", 11.5, 2.0, kind=300, remarks="moved"),
                   "old_name": "desk"}, "mod")
    await request(w, f"{MM}/delete_poi", "map_messages/DeletePointOfInterest",
                  {"name": "door"}, "del")
    await w.until(lambda: names(w) == ["dock", "desk 2"], 5, "modified and deleted")
    reply = await w.call(f"{MM}/get_pois")
    pois = reply["values"]["poi_list"]["pois"]
    assert [p["name"] for p in pois] == ["dock", "desk 2"]
    assert pois[1]["type"] == 300 and pois[1]["remarks"] == "moved"
    assert pois[1]["pose"]["position"]["x"] == 11.5
    # a late subscriber gets the latched list
    late = await Watcher.open(_server.port)
    await late.subscribe(f"{MM}/pois")
    got = await late.until(lambda: late.latest(f"{MM}/pois"), 5, "the latched POIs")
    assert [p["name"] for p in got["pois"]] == ["dock", "desk 2"]
    await late.close()
    await w.close()


def check_map_server_files(folder) -> tuple[dict, np.ndarray]:
    """Parse a saved map as ROS map_server would, independently of the server's code."""
    doc = yaml.safe_load((folder / "map.yaml").read_text())
    assert set(doc) >= {"image", "resolution", "origin", "negate", "occupied_thresh",
                        "free_thresh"}
    assert doc["negate"] == 0 and doc["occupied_thresh"] == 0.65
    assert doc["free_thresh"] == 0.196 and doc.get("mode", "trinary") == "trinary"
    assert len(doc["origin"]) == 3 and all(isinstance(v, float) for v in doc["origin"])
    raw = (folder / doc["image"]).read_bytes()
    assert raw.startswith(b"P5")
    with Image.open(io.BytesIO(raw)) as image:
        assert image.format == "PPM" and image.mode == "L"
        pixels = np.asarray(image)
    assert set(np.unique(pixels)) <= {0, 205, 254}
    p = (255.0 - pixels) / 255.0
    occupancy = np.where(p > doc["occupied_thresh"], 100,
                         np.where(p < doc["free_thresh"], 0, -1))
    return doc, np.flipud(occupancy)


async def test_save_restart_load_round_trips_map_masks_and_pois(make_server, tmp_path):
    server, w = await start(make_server, tmp_path)
    await w.subscribe(f"{NS}/map", "nav_msgs/OccupancyGrid")
    robot_map = await w.until(lambda: w.latest(f"{NS}/map"), 10, "the robot's map")
    await request(w, f"{MM}/add_poi", POI_T, poi("kitchen", 19.0, 3.0, 1.0, kind=200,
                                                   remarks="Küche"), "a1")
    await request(w, f"{MM}/add_poi", POI_T, poi("office B", 10.0, 12.5), "a2")
    ok = await modify_map(w, "mask", rect(8.3, 8.8, 9.4, 9.4), BLOCKED)
    assert ok["level"] == "info", ok
    await modify_map(w, "obst", rect(14.0, 7.5, 14.4, 7.9), OBSTACLE, layer=SICK_LAYER)
    saved = await request(w, f"{MM}/save_map", SAVE_T, {"filename": "navigation"}, "save")
    assert saved["level"] == "info" and "saved map 'navigation'" in saved["msg"], saved
    folder = tmp_path / "navigation"
    assert sorted(os.listdir(tmp_path)) == ["navigation"]
    assert {"map.yaml", "map.pgm", "masks.yaml", "pois.yaml"} <= set(os.listdir(folder))

    # the map is valid map_server input and equals the robot's map
    doc, occupancy = check_map_server_files(folder)
    info = robot_map["info"]
    assert doc["resolution"] == pytest.approx(info["resolution"])
    assert doc["origin"][:2] == pytest.approx([info["origin"]["position"]["x"],
                                               info["origin"]["position"]["y"]])
    assert occupancy.shape == (info["height"], info["width"])
    assert occupancy.ravel().tolist() == list(robot_map["data"])
    masks = yaml.safe_load((folder / "masks.yaml").read_text())
    # every layer's masks are kept, shown or not (the SICK layer is off by default)
    assert [e["layer"] for e in masks["layers"]] == [MASKING_LAYER, SICK_LAYER]
    assert masks["layers"][0]["image"] in os.listdir(folder)
    assert [p["name"] for p in yaml.safe_load((folder / "pois.yaml").read_text())["pois"]] == [
        "kitchen", "office B"]
    await w.close()
    await server.stop()

    # a new server on the same map store starts empty; loading brings everything back
    server, w = await start(make_server, tmp_path)
    await w.subscribe(f"{NS}/map", "nav_msgs/OccupancyGrid")
    assert names(w) == []
    assert cell(w.latest("/map"), 8.85, 9.1) != BLOCKED
    await w.until(lambda: w.latest(f"{NS}/map"), 10, "the robot's map")
    await w.publish("/map", small_map(), "nav_msgs/OccupancyGrid")  # something else entirely
    await w.until(lambda: w.latest(f"{NS}/map")["info"]["width"] == 120, 10,
                  "the robot's map replaced")
    loaded = await request(w, f"{MM}/load_map", SAVE_T, {"filename": "navigation"}, "load")
    assert loaded["level"] == "info" and "loaded map 'navigation'" in loaded["msg"], loaded
    await w.until(lambda: names(w) == ["kitchen", "office B"], 5, "the POIs back")
    kitchen = w.latest(f"{MM}/pois")["pois"][0]
    assert kitchen["type"] == 200 and kitchen["remarks"] == "Küche"
    assert kitchen["pose"]["orientation"]["z"] == pytest.approx(math.sin(0.5))
    await w.until(lambda: cell(w.latest("/map"), 8.85, 9.1) == BLOCKED, 5, "the mask back")
    await w.until(lambda: list(w.latest(f"{NS}/map")["data"]) == list(robot_map["data"]), 10,
                  "the robot's map restored")
    assert w.latest(f"{NS}/map")["info"]["width"] == robot_map["info"]["width"]
    await w.close()


async def test_bad_folder_names_are_refused_and_touch_nothing(make_server, tmp_path):
    store = tmp_path / "store"
    _server, w = await start(make_server, store)
    bad = {"traversal": "../x", "empty": "", "absolute": str(tmp_path / "abs"),
           "long": "x" * 65, "dot": "..", "sep": "a/b"}
    for op_id, name in bad.items():
        for verb in ("save", "load"):
            status = await request(w, f"{MM}/{verb}_map", SAVE_T, {"filename": name},
                                   f"{verb}-{op_id}")
            assert status["level"] == "error" and "map folder name" in status["msg"], status
    missing = await request(w, f"{MM}/load_map", SAVE_T, {"filename": "never"}, "missing")
    assert missing["level"] == "error" and "no saved map named 'never'" in missing["msg"]
    assert os.listdir(tmp_path) == []  # neither the store nor anything beside it was created
    ok = await request(w, f"{MM}/save_map", SAVE_T, {"filename": "localization"}, "ok")
    assert ok["level"] == "info", ok
    assert os.listdir(tmp_path) == ["store"] and os.listdir(store) == ["localization"]
    await w.close()


async def test_layer_toggling_republishes_the_map(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path)
    await modify_map(w, "mask", rect(6.0, 7.5, 6.5, 8.5), BLOCKED)
    await w.until(lambda: cell(w.latest("/map"), 6.25, 8.0) == BLOCKED, 5, "the mask drawn")

    async def toggle(layer: int, state: bool, op_id: str) -> dict:
        count = len(w.messages["/map"])
        status = await request(w, f"{MM}/map_layers", "map_messages/MapLayers",
                               {"layer": layer, "state": state}, op_id)
        assert status["level"] == "info", status
        await w.until(lambda: len(w.messages["/map"]) > count, 5, f"/map after {op_id}")
        return w.messages["/map"][count][1]

    grid = await toggle(MASKING_LAYER, False, "mask-off")
    assert cell(grid, 6.25, 8.0) == 0
    grid = await toggle(MASKING_LAYER, True, "mask-on")
    assert cell(grid, 6.25, 8.0) == BLOCKED
    grid = await toggle(SLAM_LAYER, False, "slam-off")
    assert set(grid["data"]) == {-1, BLOCKED}
    await toggle(SLAM_LAYER, True, "slam-on")
    grid = await toggle(SICK_LAYER, True, "sick-on")
    # the lidar's obstacles: the corridor walls left and right of the robot at (5, 8)
    await w.until(lambda: sum(1 for v in w.latest("/map")["data"] if v == OBSTACLE) > 0, 5,
                  "lidar hits in the SICK layer")
    seen = w.latest("/map")
    assert cell(seen, 5.0, 8.0) in (0, -1)
    # lidar updates (10 Hz) republish /map at most twice a second
    count = len(w.messages["/map"])
    await asyncio.sleep(2.0)
    assert len(w.messages["/map"]) - count <= 5
    again = await toggle(SICK_LAYER, False, "sick-off")
    assert OBSTACLE not in set(again["data"])
    status = await request(w, f"{MM}/map_layers", "map_messages/MapLayers",
                           {"layer": 7, "state": True}, "bad-layer")
    assert status["level"] == "error" and "layer" in status["msg"]
    status = await modify_map(w, "bad-action", rect(0, 0, 1, 1), 5)
    assert status["level"] == "error" and "maskAction" in status["msg"]
    status = await modify_map(w, "bad-region", rect(0, 0, 1, 1)[:2], BLOCKED)
    assert status["level"] == "error" and "at least 3 points" in status["msg"]
    status = await modify_map(w, "unmask", rect(5.9, 7.4, 6.6, 8.6), NOT_MASKED)
    assert status["level"] == "info"
    await w.until(lambda: cell(w.latest("/map"), 6.25, 8.0) == 0, 5, "the mask removed")
    await w.close()


def small_map() -> dict:
    """A 6 m x 4 m room at 10 cm (the robot's map is at 5 cm: it gets resampled)."""
    width, height, res = 60, 40, 0.1
    data = np.zeros((height, width), dtype=int)
    data[:, 0] = data[:, -1] = data[0, :] = data[-1, :] = 100
    data[15:25, 28:32] = 100  # a pillar
    return {"header": {"frame_id": "/map"},
            "info": {"resolution": res, "width": width, "height": height,
                     "origin": {"position": {"x": 2.0, "y": 6.0, "z": 0.0},
                                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
            "data": data.ravel().tolist()}


async def test_a_client_map_on_slash_map_replaces_the_robot_map(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path)
    await w.subscribe(f"{NS}/map", "nav_msgs/OccupancyGrid")
    await w.until(lambda: w.latest(f"{NS}/map"), 10, "the robot's map")
    grid = small_map()
    await w.publish("/map", grid, "nav_msgs/OccupancyGrid", op_id="replace")
    await w.until(lambda: w.latest(f"{NS}/map")["info"]["width"] == 120, 10,
                  "the robot's map replaced")
    robot = w.latest(f"{NS}/map")
    assert robot["info"]["height"] == 80
    assert cell(robot, 5.05, 7.95) == 100 and cell(robot, 3.0, 7.0) == 0
    await w.until(lambda: w.latest("/map")["info"]["width"] == 120, 5, "/map recomposed")
    bad = dict(grid, data=[0, 0, 0])
    await w.publish("/map", bad, op_id="bad-map")
    status = await w.until(lambda: next((s for s in w.statuses if s.get("id") == "bad-map"
                                         and s["level"] == "error"), None), 5, "an error")
    assert "width x height" in status["msg"]
    await w.close()


async def test_do_mapping_toggles_the_robot_map_update(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path)
    await w.subscribe(f"{NS}/robot_basic_state")
    state = f"{NS}/robot_basic_state"
    await w.until(lambda: w.latest(state), 5, "the robot state")
    assert w.latest(state)["is_map_building_enabled"] is False
    await request(w, f"{MM}/do_mapping", "map_messages/DoMapping", {"state": True}, "on")
    await w.until(lambda: w.latest(state)["is_map_building_enabled"] is True, 5, "mapping on")
    await request(w, f"{MM}/do_mapping", "map_messages/DoMapping", {"state": False}, "off")
    await w.until(lambda: w.latest(state)["is_map_building_enabled"] is False, 5, "mapping off")
    await w.close()


async def test_blocked_areas_are_handed_over_again_after_a_reconnect(make_server, tmp_path):
    server, w = await start(make_server, tmp_path)
    status = await modify_map(w, "mask", rect(6.0, 7.5, 6.5, 8.5), BLOCKED)
    assert status["level"] == "info", status
    sim = server.robot.simulator
    assert len(sim.map.blocked) == 1
    await server.robot.link.stop()  # the robot goes away and forgets its blocked areas
    sim.map.set_blocked_areas([])
    await asyncio.sleep(0.8)
    await server.robot.link.start()
    await w.until(lambda: len(sim.map.blocked) == 1, 5, "the blocked areas handed over again")
    await w.close()


async def test_start_up_cleans_leftovers_and_load_refuses_a_link_outside(make_server, tmp_path):
    maps = tmp_path / "maps"
    (maps / ".tmp-navigation.0a0b").mkdir(parents=True)
    (maps / ".old-navigation.0c0d").mkdir()
    for folder in ("routes", "graphs"):  # kill -9 during a save of a route or graph file
        (tmp_path / folder).mkdir()
        (tmp_path / folder / ".tmp-lap.yaml.0e0f").write_bytes(b"half a ")
        (tmp_path / folder / "lap.yaml").write_bytes(b"kept")
    evil = maps / "evil"
    evil.mkdir()
    (evil / "map.yaml").write_text("image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n"
                                   "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    outside = tmp_path / "outside.pgm"
    outside.write_bytes(b"P5\n1 1\n255\n\x00")
    (evil / "map.pgm").symlink_to(outside)
    _server, w = await start(make_server, maps)
    # the leftovers are gone before any client could see them
    assert sorted(p.name for p in maps.iterdir()) == ["evil", "navigation"]
    for folder in ("routes", "graphs"):
        assert [p.name for p in (tmp_path / folder).iterdir()] == ["lap.yaml"]
    refused = await request(w, f"{MM}/load_map", SAVE_T, {"filename": "evil"}, "evil")
    assert refused["level"] == "error" and "outside the map store" in refused["msg"]
    got = await w.call(f"{MM}/get_pois")
    assert got["result"] is True
    await w.close()


async def test_home_dock_is_latched_and_follows_the_robot(make_server, tmp_path):
    """``/map_manager/home``: where the dock is (consoles draw it); republished on a change."""
    server, w = await start(make_server, tmp_path)
    await w.subscribe(f"{MM}/home", "geometry_msgs/PoseStamped")
    first = await w.until(lambda: w.latest(f"{MM}/home"), 10, "the dock's pose")
    dock = await server.robot.maps.get_home_pose()
    assert first["header"]["frame_id"] == "/map"
    p = first["pose"]["position"]
    assert (p["x"], p["y"]) == (pytest.approx(dock.x), pytest.approx(dock.y))
    moved = type(dock)(dock.x + 1.0, dock.y, dock.yaw)
    await server.robot.maps.set_home_pose(moved)
    changed = await w.until(lambda: (m := w.latest(f"{MM}/home")) and
                            m["pose"]["position"]["x"] == pytest.approx(moved.x) and m, 10,
                            "the moved dock")
    assert changed["header"]["frame_id"] == "/map"
    # a late subscriber gets it from the latch
    late = await Watcher.open(server.port)
    try:
        await late.subscribe(f"{MM}/home", "geometry_msgs/PoseStamped")
        got = await late.until(lambda: late.latest(f"{MM}/home"), 5, "the latched dock")
        assert got["pose"]["position"]["x"] == pytest.approx(moved.x)
    finally:
        await late.close()


POI_BURST = 1000
"""add_poi requests written back to back on one connection (issue 52: each copied the whole
list twice, 8.7 s for a thousand and the witness stalled 1.3 s)."""


@pytest.mark.serial  # the witness's bound: run alone (tests/run.py)
async def test_a_burst_of_poi_adds_is_cheap_and_each_is_kept(make_server, tmp_path):
    server, w = await start(make_server, tmp_path)
    client = await WsClient.open(server.port)
    try:
        await client.send({"op": "set_level", "id": "lv", "level": "info"})
        await client.expect(op="status", id="lv")
        await client.send({"op": "advertise", "topic": f"{MM}/add_poi", "type": POI_T})
        witness = await RoundTrips.open(server.port)
        for i in range(POI_BURST):
            await client.send({"op": "publish", "id": f"p{i}", "topic": f"{MM}/add_poi",
                               "msg": poi(f"p{i}", 6.0 + (i % 10) * 0.1, 8.0)})
        answers = [await client.expect(op="status", timeout=60) for _ in range(POI_BURST)]
        worst = await witness.stop()
        assert all(a["level"] == "info" for a in answers), answers[0]
        listed = await w.call(f"{MM}/get_pois", timeout=30)
        assert [p["name"] for p in listed["values"]["poi_list"]["pois"]] == [
            f"p{i}" for i in range(POI_BURST)]
        assert worst <= 0.5, witness.times
    finally:
        await client.close()
        await w.close()

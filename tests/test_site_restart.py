"""The site of a real ``hitrobot-server`` process with two named simulated robots is a part of
its own: its POIs, masks and zones are kept in ``<state-dir>/site/`` and come back whatever
became of the robot whose map feeds it (renamed, removed); and a state folder of the layout
before it (the site's map-manager sections in the first robot's folder) is upgraded on the
first start, with nothing lost and nothing moved twice."""

from __future__ import annotations

import asyncio

from hitrobot_server.nodes.fleet.zones import Zone
from hitrobot_server.nodes.map_manager.layers import BLOCKED, MASKING_LAYER, Mask
from hitrobot_server.nodes.map_manager.pois import normalize
from hitrobot_server.nodes.map_manager.sections import encode_masks
from hitrobot_server.robot.factory import sim_identity
from hitrobot_server.robot.options import RobotOptions
from hitrobot_server.robot.sim.world import load_world
from hitrobot_server.state import StateStore, identity_folder
from tests.helpers import ServerProcess, Watcher
from tests.nodes.fleet.test_zones import polygon
from tests.nodes.map_manager.util import MM, cell, modify_map, poi, rect, request

POI_T = "map_messages/PointOfInterest"
MASK = (8.0, 3.0, 8.6, 3.6)
DOOR = [(11.0, 7.2), (13.0, 7.2), (13.0, 8.8), (11.0, 8.8)]  # robot b stands in it
A, B = "a=sim@6,8", "b=sim@12,8"


def server(state, maps, first: str, *others: str, extra: tuple[str, ...] = ()) -> ServerProcess:
    robots = [arg for other in others for arg in ("--robot", other)]
    return ServerProcess(*robots, "--sim-speed", "4", "--state-dir", str(state), "--map-dir",
                         str(maps), *extra, robot=first)


async def site_watcher(port: int, robots: int) -> Watcher:
    w = await Watcher.open(port)
    await w.client.send({"op": "set_level", "level": "info"})
    for topic in ("/fleet/robots", "/fleet/zones", "/map"):
        await w.subscribe(topic)
    await w.until(lambda: sum(r["state"] == "idle" for r in (
        w.latest("/fleet/robots") or {"robots": []})["robots"]) == robots, 30,
        f"{robots} robots idle")
    await w.until(lambda: w.latest("/map"), 20, "the site's map")
    return w


async def poi_names(w: Watcher) -> list[str]:
    reply = await w.call(f"{MM}/get_pois")
    return [p["name"] for p in reply["values"]["poi_list"]["pois"]]


def zone_names(w: Watcher) -> list[str]:
    return [z["name"] for z in (w.latest("/fleet/zones") or {"zones": []})["zones"]]


async def the_site_is_back(w: Watcher, pois: list[str]) -> None:
    """Every POI, the mask in the composed /map and the zone."""
    assert await poi_names(w) == pois
    x, y = (MASK[0] + MASK[2]) / 2, (MASK[1] + MASK[3]) / 2
    await w.until(lambda: cell(w.latest("/map"), x, y) == BLOCKED, 10, "the mask in /map")
    await w.until(lambda: zone_names(w) == ["door_b"], 5, "the zone")


def restored_line(proc: ServerProcess, folder) -> str:
    return next(line for line in proc.output
                if "state: restored" in line and line.rstrip().endswith(str(folder)))


async def test_the_sites_pois_and_zones_stay_when_the_first_robot_goes(tmp_path):
    state, maps = tmp_path / "state", tmp_path / "maps"
    first = server(state, maps, A, B)
    try:
        w = await site_watcher(first.port, 2)
        for i, (name, x) in enumerate((("kitchen", 3.0), ("desk", 19.0))):
            assert (await request(w, f"{MM}/add_poi", POI_T, poi(name, x, 8.0), f"p{i}")
                    )["level"] == "info"
        assert (await modify_map(w, "mask", rect(*MASK), BLOCKED))["level"] == "info"
        added = await w.call("/fleet/zone_add", {"name": "door_b", "kind": "door",
                                                 "polygon": polygon(DOOR)}, timeout=30)
        assert added["values"]["success"], added
        await w.close()
    finally:
        first.kill()  # every change above was answered once on disk
    renamed = server(state, maps, "c=sim@6,8", B)  # a is c now
    try:
        w = await site_watcher(renamed.port, 2)
        await the_site_is_back(w, ["kitchen", "desk"])
        await w.close()
    finally:
        renamed.stop()
    alone = server(state, maps, B)  # the robot that fed the site's map is gone
    try:
        assert "2 POIs" in restored_line(alone, state / "site")
        w = await site_watcher(alone.port, 1)
        await the_site_is_back(w, ["kitchen", "desk"])
        await w.close()
    finally:
        alone.stop()


async def write_old_layout(state, robot_folder: str = "") -> list[dict]:
    """A state folder as a server wrote it before the site had a part of its own: the site's
    POIs, layer switches, masks and loaded map in the first robot's folder (its map manager's
    sections, ``map_manager/…``, in the values the map manager stores), the zones in the
    site's folder (``fleet/zones``, as today). ``robot_folder``: the first robot's folder
    (a simulated robot ``a``'s by default). The POIs as stored."""
    pois = [normalize(poi("kitchen", 3.0, 8.0)), normalize(poi("desk", 19.0, 8.0, kind=100))]
    mask = Mask(load_world().spec.resolution)  # the map manager paints on the map's lattice
    mask.paint([(p["x"], p["y"]) for p in rect(*MASK)], BLOCKED)
    robot = StateStore.open(identity_folder(
        state, robot_folder or sim_identity(RobotOptions(), "a")))
    site = StateStore.open(identity_folder(state, "site"))
    try:
        await asyncio.gather(
            robot.put("map_manager/pois", pois),
            robot.put("map_manager/layers", {"0": True, "1": True, "2": True, "3": False}),
            robot.put("map_manager/masks", encode_masks({MASKING_LAYER: mask})),
            site.put("fleet/zones", [Zone("door_b", "door", tuple(DOOR)).record()]))
    finally:
        await robot.close()
        await site.close()
    return pois


async def test_an_old_state_folder_is_upgraded_once(tmp_path):
    state, maps = tmp_path / "state", tmp_path / "maps"
    pois = await write_old_layout(state)
    robot_a = identity_folder(state, "sim-office-a")
    upgraded = server(state, maps, A, B)
    try:
        moved = next(line for line in upgraded.output if "state: the site's" in line)
        assert f"moved from {robot_a} to {state / 'site'}" in moved
        assert all(f"map_manager/{name}" in moved for name in ("pois", "layers", "masks"))
        assert "1 mutex zones, 2 POIs, masks on 1 layers" in restored_line(
            upgraded, state / "site")
        w = await site_watcher(upgraded.port, 2)
        await the_site_is_back(w, ["kitchen", "desk"])
        assert (await w.call(f"{MM}/get_pois"))["values"]["poi_list"]["pois"] == pois
        await w.close()
    finally:
        upgraded.stop()
    site, robot = StateStore.open(state / "site"), StateStore.open(robot_a)
    try:  # moved, not copied
        assert site.get("map_manager/pois") == pois and robot.keys("map_manager/") == []
        assert site.get("site/moved")["cleared"]
        await robot.put("map_manager/pois", [normalize(poi("stale", 5.0, 8.0))])
    finally:
        await site.close()
        await robot.close()
    again = server(state, maps, A, B)  # moved once: the robot's folder is not read for it again
    try:
        assert not any("moved from" in line for line in again.output)
        w = await site_watcher(again.port, 2)
        await the_site_is_back(w, ["kitchen", "desk"])
        await w.close()
    finally:
        again.stop()

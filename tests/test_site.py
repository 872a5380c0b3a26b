"""The site of a server with named robots (``site.py``): which robot's map feeds its map
manager (``--site-map-robot``), its folder, and a move into it cut short by a crash, finished
by the next start. Real servers on loopback, real state folders."""

from __future__ import annotations

import json

import pytest

from hitrobot_server.cli import build_parser
from hitrobot_server.config import load
from hitrobot_server.nodes.map_manager import MapManager
from hitrobot_server.nodes.map_manager.pois import normalize
from hitrobot_server.robot.options import RobotEntry
from hitrobot_server.robots import start_plan
from hitrobot_server.site import MOVED
from hitrobot_server.state import StateStore, identity_folder
from hitrobot_server.state.journal import encode_record
from hitrobot_server.state.loading import JOURNAL
from tests.helpers import Watcher
from tests.nodes.map_manager.util import MM, poi, request
from tests.state.failing_folder import FailingFolder
from tests.state.test_rest_identity import device
from tests.test_metrics import scrape
from tests.test_site_restart import write_old_layout
from tests.transport.test_http import http

ROBOTS = (RobotEntry("a", "sim", (6.0, 8.0, 0.0)), RobotEntry("b", "sim", (12.0, 8.0, 0.0)))
SLAM_MAP = "slamware_ros_sdk_server_node/map"


def parse(*argv: str):
    return load(build_parser().parse_args(list(argv)))


def fed_by(server) -> list[str]:
    """The robots whose SLAM map the site's map manager takes."""
    return [name for name in ("a", "b") if any(
        node == "/map_manager" for node, _ in server.bus.topics[f"/{name}/{SLAM_MAP}"]
        .subscribers.values())]


async def pois_of(server) -> list[str]:
    w = await Watcher.open(server.port)
    try:
        reply = await w.call(f"{MM}/get_pois")
        return [p["name"] for p in reply["values"]["poi_list"]["pois"]]
    finally:
        await w.close()


def test_the_plan_names_the_robot_that_feeds_the_site_map():
    assert start_plan(parse("--robot", "a=sim", "--robot", "b=sim")).site_map == "a"
    assert start_plan(parse("--robot", "a=none", "--robot", "b=sim")).site_map == "b"
    chosen = parse("--robot", "a=sim", "--robot", "b=sim", "--site-map-robot", "b")
    assert start_plan(chosen).site_map == "b"
    assert start_plan(parse("--robot", "sim")).site_map == ""  # a single robot: no site


@pytest.mark.parametrize(("argv", "error"), [
    (["--robot", "a=sim", "--robot", "b=sim", "--site-map-robot", "c"],
     "--site-map-robot 'c' is not one of the robots (a, b)"),
    (["--robot", "a=none", "--robot", "b=sim", "--site-map-robot", "a"],
     "robot 'a' is 'none', it has no map"),
    (["--robot", "sim", "--site-map-robot", "a"], "a single robot has no site"),
])
def test_a_site_map_robot_that_cannot_feed_it_is_refused(argv, error):
    with pytest.raises(ValueError, match=error.replace("(", r"\(").replace(")", r"\)")):
        parse(*argv)


async def test_the_site_map_is_the_chosen_robots_and_the_site_owns_it(make_server, tmp_path):
    state = tmp_path / "state"
    server = await make_server(robots=ROBOTS, map_dir=str(tmp_path), state_dir=str(state),
                               site_map_robot="b")
    assert fed_by(server) == ["b"]
    assert isinstance(server.site.map_manager, MapManager)
    assert server.site.state.store.path == state / "site"
    assert not [n for u in server.robots for n in u.nodes if isinstance(n, MapManager)]
    await server.stop()
    first = await make_server(robots=ROBOTS, map_dir=str(tmp_path), state_dir=str(state))
    assert fed_by(first) == ["a"]  # by default the first robot's


async def test_a_move_cut_short_after_the_sites_line_is_finished(make_server, tmp_path):
    """A crash after the site's folder took the sections (one line) and before the robot's
    folder gave them up: the next start serves the site's and clears the robot's copies."""
    state = tmp_path / "state"
    pois = await write_old_layout(state)
    robot = StateStore.open(identity_folder(state, "sim-office-a"))
    site = StateStore.open(identity_folder(state, "site"))
    try:
        names = robot.keys("map_manager/")
        for key in names:
            await site.put(key, robot.get(key))
        await site.put(MOVED, {"from": "sim-office-a", "sections": names, "cleared": False})
    finally:
        await robot.close()
        await site.close()
    server = await make_server(robots=ROBOTS, map_dir=str(tmp_path), state_dir=str(state))
    assert await pois_of(server) == ["kitchen", "desk"]
    assert server.robots[0].state.store.keys("map_manager/") == []
    assert server.site.state.store.get(MOVED)["cleared"]
    assert server.site.state.store.get("map_manager/pois") == pois


async def test_a_move_torn_in_the_sites_journal_is_done_again(make_server, tmp_path):
    """A crash while the site's line was being written (its tail torn): the site's folder has
    none of it, the robot's folder all of it, and the next start moves it."""
    state = tmp_path / "state"
    pois = await write_old_layout(state)
    torn = encode_record(99, {"map_manager/pois": pois, MOVED: {"from": "sim-office-a"}})
    with open(identity_folder(state, "site") / JOURNAL, "ab") as journal:
        journal.write(torn[:len(torn) // 2])
    server = await make_server(robots=ROBOTS, map_dir=str(tmp_path), state_dir=str(state))
    assert await pois_of(server) == ["kitchen", "desk"]
    assert server.site.state.store.get("map_manager/pois") == pois
    assert server.robots[0].state.store.keys("map_manager/") == []


async def test_a_rest_first_robots_folder_is_moved_once_it_answers(make_server, tmp_path):
    """The first robot is a real robot over REST: its folder is known only once it says who
    it is; then the site's sections move from it and the map manager serves them."""
    state = tmp_path / "state"
    dev = await device(1)
    try:
        folder = "slamware-" + dev.simulator.device_info().device_id
        pois = await write_old_layout(state, folder)
        server = await make_server(robots=(RobotEntry("a", dev.url), ROBOTS[1]),
                                   map_dir=str(tmp_path), state_dir=str(state))
        w = await Watcher.open(server.port)
        try:
            await w.subscribe(f"{MM}/pois")
            await w.until(lambda: [p["name"] for p in (w.latest(f"{MM}/pois") or {"pois": []})[
                "pois"]] == ["kitchen", "desk"], 20, "the POIs moved from the robot's folder")
        finally:
            await w.close()
        assert server.site.state.store.get("map_manager/pois") == pois
        assert server.site.state.store.get(MOVED)["from"] == folder
        assert server.robots[0].state.store.keys("map_manager/") == []
        await server.stop()
    finally:
        await dev.stop()


async def test_a_single_robot_keeps_its_own_map_manager_and_folder(make_server, tmp_path):
    state = tmp_path / "state"
    server = await make_server(robot="sim", map_dir=str(tmp_path), state_dir=str(state))
    assert server.site.map_manager is None and server.site.state.store is None
    unit = server.robots[0]
    assert [n for n in unit.nodes if isinstance(n, MapManager)]
    assert server.bus.service("/map_manager/get_pois") is not None
    assert not (state / "site").exists()
    assert unit.state.store.path == state / "sim-office"
    w = await Watcher.open(server.port)
    try:
        await w.client.send({"op": "set_level", "level": "info"})
        await w.client.send({"op": "advertise", "topic": f"{MM}/add_poi",
                             "type": "map_messages/PointOfInterest"})
        await w.publish(f"{MM}/add_poi", poi("kitchen", 3.0, 8.0), op_id="p")
        await w.until(lambda: any(s.get("id") == "p" and s["level"] == "info"
                                  for s in w.statuses), 10, "the POI acknowledged")
    finally:
        await w.close()
    assert unit.state.store.get("map_manager/pois") == [normalize(poi("kitchen", 3.0, 8.0))]


async def health(port: int) -> tuple[int, dict]:
    status, _headers, body = await http(port, "GET", "/healthz")
    return status, json.loads(body)


async def test_a_site_folder_that_cannot_be_written_fails_the_health_check(make_server,
                                                                          tmp_path):
    """Its folder holds the site's POIs and the fleet's tasks: a write that fails there is
    seen in ``/healthz`` and ``/metrics`` as one of a robot's folder is."""
    folder = FailingFolder(tmp_path / "state")
    try:
        server = await make_server(robots=ROBOTS, map_dir=str(tmp_path / "maps"),
                                   state_dir=str(folder.root))
        status, checks = await health(server.port)
        site = checks["state"]["site"]
        assert status == 200 and site["ok"] and site["writes"] >= 1 and not site["last_error"]
        assert [s["robot"] for s in checks["state"]["stores"]] == ["a", "b"]
        assert (await scrape(server.port))["hitrobot_site_state_write_failures_total"][()] == 0
        folder.fail(folder.root / "site")
        w = await Watcher.open(server.port)
        try:
            refused = await request(w, f"{MM}/add_poi", "map_messages/PointOfInterest",
                                    poi("while_full", 4.0, 8.0, remarks="x" * 6000), "p")
            assert refused["level"] == "error", refused
        finally:
            await w.close()
        status, checks = await health(server.port)
        assert status == 503 and checks["state"]["site"] == {
            "ok": False, "writes": site["writes"], "last_error": folder.reason}
        assert (await scrape(server.port))["hitrobot_site_state_write_failures_total"][()] >= 1
        await server.stop()  # before the folder goes
    finally:
        folder.close()

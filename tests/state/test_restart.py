"""The site's state survives SIGKILL: real server processes on one state folder, driven and
checked through the protocol (raw WebSocket), as an operator's tools would."""

from __future__ import annotations

import math
import random

from tests.helpers import ServerProcess, Watcher
from tests.nodes.map_manager.util import (
    BLOCKED,
    MM,
    NS,
    cell,
    current,
    modify_map,
    poi,
    rect,
    request,
)
from tests.nodes.test_graph import EDGES, NODES

POI_T = "map_messages/PointOfInterest"
ROUTE = [{"frame": "map", "x": 2.5, "y": 8.0, "z": 0.0, "use_z": False},
         {"frame": "map", "x": 7.0, "y": 8.0, "z": 0.0, "use_z": False}]
WALL = ((14.0, 2.0), (14.0, 3.0))
TRACK = ((15.0, 2.0), (16.0, 2.0))
GOAL = (20.0, 8.2)
MASK = (8.0, 3.0, 8.6, 3.6)
WINDOW = 20


def line(i: int, ends) -> dict:
    (x0, y0), (x1, y1) = ends
    return {"id": i, "start": {"x": x0, "y": y0}, "end": {"x": x1, "y": y1}}


async def watch(port: int) -> Watcher:
    w = await Watcher.open(port)
    await w.client.send({"op": "set_level", "level": "info"})
    for topic in ("odom", "virtual_walls", "virtual_tracks"):
        await w.subscribe(f"{NS}/{topic}")
    for topic in ("/map", f"{MM}/pois", "/planning/patrol_state", "/graph/current",
                  "/diagnostics_agg"):
        await w.subscribe(topic)
    await w.until(lambda: w.latest(f"{NS}/odom") and w.latest("/map"), 20, "odometry and map")
    return w


def diagnostic(w: Watcher, name: str) -> dict | None:
    got = w.latest("/diagnostics_agg")
    return next((s for s in got["status"] if s["name"] == name), None) if got else None


def value(item: dict, key: str) -> str:
    return next(v["value"] for v in item["values"] if v["key"] == key)


def lines_of(w: Watcher, topic: str) -> list[tuple[float, ...]]:
    got = w.latest(f"{NS}/{topic}") or {"lines": []}
    return [tuple(round(p[k], 3) for p in (ln["start"], ln["end"]) for k in "xy")
            for ln in got["lines"]]


def acks(w: Watcher, names: list[str]) -> list[str]:
    """The publish ops of ``names`` the map manager acknowledged (an info status)."""
    wanted = set(names)
    return [s["id"] for s in w.statuses if s["level"] == "info" and s.get("id") in wanted]


def server(state_dir, map_dir) -> ServerProcess:
    return ServerProcess("--state-dir", str(state_dir), "--map-dir", str(map_dir),
                         "--sim-speed", "4", robot="sim")


async def test_an_operators_setup_survives_sigkill(tmp_path):
    state, maps = tmp_path / "state", tmp_path / "maps"
    first = server(state, maps)
    try:
        assert any("state: started fresh in" in line for line in first.output)
        w = await watch(first.port)
        assert (await request(w, f"{MM}/add_poi", POI_T, poi("kitchen", 3.0, 8.0), "p1")
                )["level"] == "info"
        assert (await modify_map(w, "mask", rect(*MASK), BLOCKED))["level"] == "info"
        assert (await w.call("/planning/set_waypoints", {"waypoints": ROUTE}))["values"][
            "success"]
        assert (await w.call("/save_graph_file", {"name": "floor", "nodes": NODES,
                                                  "edges": EDGES}))["values"]["success"]
        await w.publish(f"{NS}/move_to", {"location": {"x": GOAL[0], "y": GOAL[1], "z": 0.0},
                                          "yaw": 0.0, "options": {
                                              "opt_flags": {"flags": 0},
                                              "speed_ratio": {"is_valid": False, "value": 0.0}}},
                        "slamware_ros_sdk/MoveToRequest")
        await w.until(lambda: math.dist(current(w)[:2], GOAL) < 0.3
                      and abs(w.latest(f"{NS}/odom")["twist"]["twist"]["linear"]["x"]) < 1e-3,
                      90, "the robot in the other room")
        await w.publish(f"{NS}/add_line", {"usage": {"usage": 0}, "line": line(1, WALL)},
                        "slamware_ros_sdk/AddLineRequest")
        await w.publish(f"{NS}/add_line", {"usage": {"usage": 1}, "line": line(2, TRACK)},
                        "slamware_ros_sdk/AddLineRequest")
        await w.until(lambda: lines_of(w, "virtual_walls") and lines_of(w, "virtual_tracks"),
                      10, "the wall and the track")
        # the last acknowledged change: everything before it is on disk too
        assert (await request(w, f"{MM}/add_poi", POI_T, poi("desk", 19.0, 8.2), "p2")
                )["level"] == "info"
        before = current(w)
        await w.close()
    finally:
        first.kill()

    second = server(state, maps)
    try:
        restored = next(line for line in second.output if "state: restored" in line)
        assert "2 POIs" in restored and "1 wall," in restored and "robot pose" in restored
        w = await watch(second.port)
        reply = await w.call(f"{MM}/get_pois")
        assert [p["name"] for p in reply["values"]["poi_list"]["pois"]] == ["kitchen", "desk"]
        await w.until(lambda: lines_of(w, "virtual_walls") == [(*WALL[0], *WALL[1])]
                      and lines_of(w, "virtual_tracks") == [(*TRACK[0], *TRACK[1])],
                      10, "the wall and the track back")
        x, y = (MASK[0] + MASK[2]) / 2, (MASK[1] + MASK[3]) / 2
        await w.until(lambda: cell(w.latest("/map"), x, y) == BLOCKED, 10, "the mask back")
        await w.until(lambda: w.latest("/planning/patrol_state"), 10, "the route")
        assert [(p["x"], p["y"]) for p in w.latest("/planning/patrol_state")["waypoints"]] == [
            (2.5, 8.0), (7.0, 8.0)]
        await w.until(lambda: w.latest("/graph/current"), 10, "the graph")
        graph = w.latest("/graph/current")
        assert graph["name"] == "floor" and len(graph["nodes"]) == len(NODES)
        after = current(w)
        assert math.dist(before[:2], after[:2]) < 0.3, (before, after)
        loc = await w.until(lambda: diagnostic(w, "/Robot/Localization"), 10, "localization")
        assert int(value(loc, "quality")) >= 50 and value(loc, "localization enabled") == "true"
        store = await w.until(lambda: diagnostic(w, "/Bridge/State"), 10, "the store entry")
        assert store["message"] == f"state restored from {state / 'sim-office'}"
        await w.close()
    finally:
        second.stop()


async def test_fresh_sets_the_old_state_aside(tmp_path):
    state, maps = tmp_path / "state", tmp_path / "maps"
    first = server(state, maps)
    try:
        w = await watch(first.port)
        assert (await request(w, f"{MM}/add_poi", POI_T, poi("kitchen", 3.0, 8.0), "p1")
                )["level"] == "info"
        await w.close()
    finally:
        first.kill()
    second = ServerProcess("--state-dir", str(state), "--map-dir", str(maps), "--fresh",
                           robot="sim")
    try:
        assert any("state: started fresh in" in line for line in second.output)
        w = await watch(second.port)
        assert (await w.call(f"{MM}/get_pois"))["values"]["poi_list"]["pois"] == []
        await w.close()
    finally:
        second.stop()
    aside = list((state / "sim-office" / "set-aside").iterdir())
    assert any(p.name.startswith("journal.log.fresh") for p in aside)  # kept, not deleted


async def test_sigkill_during_a_burst_keeps_a_prefix_of_the_changes(tmp_path):
    """Bursts of 200 POIs published back to back; the server is killed at seeded random
    points once some were acknowledged. After each restart the POIs are exactly the first n
    of the bursts, n at least the number acknowledged: nothing torn, nothing reordered,
    nothing acknowledged lost."""
    rng = random.Random(21)
    state, maps = tmp_path / "state", tmp_path / "maps"
    expected: list[str] = []  # every POI ever published, in order
    acked: list[str] = []
    proc = server(state, maps)
    try:
        for round_ in range(3):
            w = await watch(proc.port)
            got = [p["name"] for p in
                   (await w.call(f"{MM}/get_pois"))["values"]["poi_list"]["pois"]]
            assert got == expected[:len(got)], got[:5]  # a prefix of all changes so far
            assert set(acked) <= set(got)  # nothing acknowledged was lost
            expected = got  # the lost tail is gone for good: later bursts follow what is kept
            burst = [f"r{round_}-{i:03d}" for i in range(200)]
            await w.client.send({"op": "advertise", "topic": f"{MM}/add_poi", "type": POI_T})
            kill_after = rng.randrange(1, 200)
            sent = 0
            for _ in range(400):  # the client keeps sending while acks come back, so the
                done = len(acks(w, burst))  # kill lands mid-burst (<= WINDOW unacked)
                if done >= kill_after:
                    break
                while sent < len(burst) and sent < done + WINDOW:
                    await w.client.send({"op": "publish", "topic": f"{MM}/add_poi",
                                         "id": burst[sent], "msg": poi(burst[sent], 1.0, 8.0)})
                    sent += 1
                await w.until(lambda w=w, b=burst, n=done: len(acks(w, b)) > n, 30,
                              "the next acknowledgement")
            expected = expected + burst[:sent]
            acked = acks(w, burst)
            proc.kill()
            proc = server(state, maps)
        w = await watch(proc.port)
        got = [p["name"] for p in (await w.call(f"{MM}/get_pois"))["values"]["poi_list"]["pois"]]
        assert got == expected[:len(got)] and set(acked) <= set(got)
    finally:
        proc.kill()

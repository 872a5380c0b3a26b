"""State restores exactly: every latched topic a client sees before a kill -9 it sees again,
message for message, after the server restarts on the same state folder (issue 33, item 6).

Compared whole, except time stamps: every field named ``stamp`` (``header.stamp``, action
status stamps) and ``map_load_time`` (``info`` of a map, ``map_metadata``): they say when a
message was made, and a restarted server makes them again."""

from __future__ import annotations

import contextlib
import json

from tests.helpers import ServerProcess, Watcher
from tests.nodes.map_manager.util import BLOCKED, MM, NS, cell, modify_map, poi, rect, request

POI_T = "map_messages/PointOfInterest"
SAVE_T = "map_messages/SaveMap"
LINE_T = "slamware_ros_sdk/AddLineRequest"
TIMESTAMPS = {"stamp", "map_load_time"}
MASK = (8.0, 3.0, 8.6, 3.6)
OPERATED = ("/map", f"{MM}/pois", f"{MM}/home", f"{MM}/loaded_map", f"{NS}/virtual_walls",
            f"{NS}/virtual_tracks", f"{NS}/map", f"{NS}/map_metadata")
"""The latched topics :func:`operate` changes (each must have a message before and after)."""


def without_stamps(value):
    if isinstance(value, dict):
        return {k: without_stamps(v) for k, v in value.items() if k not in TIMESTAMPS}
    if isinstance(value, list):
        return [without_stamps(v) for v in value]
    return value


async def latched_topics(make_server, maps) -> dict[str, str]:
    """Every latched topic of a server with the same robot, as its bus lists them."""
    server = await make_server(robot="sim", map_dir=str(maps))
    names = {t.name: t.type_name for t in server.bus.topics.values() if t.latched}
    await server.stop()
    return names


async def take(port: int, names: dict[str, str], like: dict | None = None) -> dict:
    """Each latched topic's message as a new client gets it (a round trip after subscribing
    all of them: latched messages come first). ``like``: wait (bounded) until each topic
    that had a message there has one here, and the same (a restarted server publishes its
    restored map within a moment)."""
    w = await Watcher.open(port)
    for name, type_name in sorted(names.items()):
        await w.subscribe(name, type_name)
    # the outbox is fair: a big latched map may come after a later small reply, so the
    # operator's own topics are waited for, and a round trip covers the small ones
    await w.until(lambda: all(w.latest(n) for n in OPERATED), 20, "the operator's topics")
    await w.call("/rosapi/get_time")
    if like is not None:
        def same() -> bool:
            return all(without_stamps(w.latest(n)) == without_stamps(like[n]) for n in like)
        with contextlib.suppress(AssertionError):  # the comparison below names what differs
            await w.until(same, 20, "every latched topic as it was")
    got = {name: w.latest(name) for name in names}
    await w.close()
    return got


def differences(before: dict, after: dict) -> list[str]:
    return [f"{name}: {json.dumps(without_stamps(before[name]))[:300]} -> "
            f"{json.dumps(without_stamps(after[name]))[:300]}"
            for name in sorted(before) if without_stamps(before[name]) !=
            without_stamps(after[name])]


async def operate(w: Watcher) -> None:
    """An operator's morning: POIs, a mask, a wall and a track, a saved map loaded (its home
    and marker), another POI, then the robot's map cleared (which unloads the saved map)."""
    assert (await request(w, f"{MM}/add_poi", POI_T, poi("kitchen", 3.0, 8.0), "p1")
            )["level"] == "info"
    assert (await modify_map(w, "mask", rect(*MASK), BLOCKED))["level"] == "info"
    for usage, i, ends in ((0, 1, (14.0, 2.0, 14.0, 3.0)), (1, 2, (15.0, 2.0, 16.0, 2.0))):
        x0, y0, x1, y1 = ends
        await w.publish(f"{NS}/add_line", {"usage": {"usage": usage}, "line": {
            "id": i, "start": {"x": x0, "y": y0}, "end": {"x": x1, "y": y1}}}, LINE_T)
    await w.until(lambda: (w.latest(f"{NS}/virtual_walls") or {}).get("lines")
                  and (w.latest(f"{NS}/virtual_tracks") or {}).get("lines"), 10, "the lines")
    assert (await request(w, f"{MM}/save_map", SAVE_T, {"filename": "office_v1"}, "s1")
            )["level"] == "info"
    assert (await request(w, f"{MM}/load_map", SAVE_T, {"filename": "office_v1"}, "l1")
            )["level"] == "info"
    assert (await request(w, f"{MM}/add_poi", POI_T, poi("desk", 19.0, 8.2), "p2")
            )["level"] == "info"
    await w.publish(f"{NS}/clear_map", {"kind": {"kind": 0}}, "slamware_ros_sdk/ClearMapRequest")
    x, y = (MASK[0] + MASK[2]) / 2, (MASK[1] + MASK[3]) / 2
    await w.until(lambda: w.latest("/map") and set(w.latest("/map")["data"]) == {-1, BLOCKED}
                  and cell(w.latest("/map"), x, y) == BLOCKED, 20, "the cleared map")


async def test_every_latched_topic_comes_back_after_kill_9(make_server, tmp_path):
    state, maps = tmp_path / "state", tmp_path / "maps"
    names = await latched_topics(make_server, maps)
    assert set(OPERATED) <= set(names)
    args = ("--state-dir", str(state), "--map-dir", str(maps), "--sim-speed", "4")
    first = ServerProcess(*args, robot="sim")
    try:
        w = await Watcher.open(first.port)
        await w.client.send({"op": "set_level", "level": "info"})
        await w.subscribe("/map", "nav_msgs/OccupancyGrid")
        for topic in ("virtual_walls", "virtual_tracks"):
            await w.subscribe(f"{NS}/{topic}")
        await operate(w)
        before = await take(first.port, names)
        await w.close()
    finally:
        first.kill()
    assert before["/map"]["info"]["width"] == 480 and before["/map"]["info"]["height"] == 320
    # the robot's map cleared after the load: no saved map is loaded any more (issue 46)
    assert before[f"{MM}/loaded_map"] == {"data": ""}
    assert [p["name"] for p in before[f"{MM}/pois"]["pois"]] == ["kitchen", "desk"]
    second = ServerProcess(*args, robot="sim")
    try:
        after = await take(second.port, names, like={n: v for n, v in before.items() if v})
    finally:
        second.stop()
    assert {n for n, v in after.items() if v} == {n for n, v in before.items() if v}
    assert differences(before, after) == []

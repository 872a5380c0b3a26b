"""Mutex zones against the real server with simulated robots in one shared world: robots
crossing a corridor zone from both ends pass it one at a time (never two inside, from their
reported poses), three never deadlock, bad zones are refused (kill -9:
tests/nodes/fleet/test_zones_restart.py)."""

from __future__ import annotations

import asyncio
import math

from hitrobot_server.robot.options import RobotEntry
from tests.helpers import Watcher
from tests.nodes.fleet.test_node import Y, dispatch, idle, pose, robots, task

LONG = [(9.0, 6.9), (14.0, 6.9), (14.0, 9.1), (9.0, 9.1)]  # 5 m: a crossing takes a while
CORRIDOR = [(10.0, 6.9), (13.0, 6.9), (13.0, 9.1), (10.0, 9.1)]  # 3 m of the office corridor
LOBBY_DOOR = [(2.3, 6.4), (4.7, 6.4), (4.7, 7.6), (2.3, 7.6)]  # the lobby's (and dock's) opening
DOOR = [(14.0, 5.9), (15.0, 5.9), (15.0, 7.0), (14.0, 7.0)]  # the open plan's east door
SPEED = 4.0


def polygon(points) -> dict:
    return {"points": [{"x": x, "y": y, "z": 0.0} for x, y in points]}


def inside(points, x: float, y: float) -> bool:
    """Even-odd rule, written out here (not the server's code)."""
    hit = False
    for (ax, ay), (bx, by) in zip(points, points[1:] + points[:1], strict=True):
        if (ay > y) != (by > y) and x < ax + (y - ay) * (bx - ax) / (by - ay):
            hit = not hit
    return hit


async def start(make_server, tmp_path, *entries) -> tuple[object, Watcher]:
    server = await make_server(robots=tuple(RobotEntry(n, "sim", (x, y, 0.0))
                                            for n, x, y in entries),
                               map_dir=str(tmp_path / "maps"), sim_speed=SPEED)
    w = await Watcher.open(server.port)
    for topic in ("/fleet/robots", "/fleet/tasks", "/fleet/zones"):
        await w.subscribe(topic)
    await w.until(lambda: len(idle(w)) == len(entries), 15, "every robot idle")
    return server, w


async def add_zone(w: Watcher, name: str, kind: str, points) -> dict:
    reply = await w.call("/fleet/zone_add", {"name": name, "kind": kind,
                                             "polygon": polygon(points)}, timeout=30)
    assert reply["result"], reply
    return reply["values"]


def zones(w: Watcher) -> dict[str, dict]:
    latest = w.latest("/fleet/zones") or {"zones": []}
    return {z["name"]: z for z in latest["zones"]}


async def send(w: Watcher, x: float, y: float, robot: str) -> dict:
    """A dispatch to a named robot (three at once on a loaded machine: a generous timeout)."""
    reply = await w.call("/fleet/dispatch", {"poi": "", "pose": pose(x, y), "robot": robot},
                         timeout=45)
    return reply["values"]


def never_two_inside(w: Watcher, points) -> int:
    """Every sampled /fleet/robots: at most one robot's pose inside; the count of samples with
    one inside (the test checks some robot was seen in it)."""
    seen = 0
    for _, msg in w.messages["/fleet/robots"]:
        within = [r["name"] for r in msg["robots"]
                  if inside(points, r["pose"]["position"]["x"], r["pose"]["position"]["y"])]
        assert len(within) <= 1, f"{within} inside the zone at once"
        seen += bool(within)
    return seen


async def test_two_robots_pass_a_mutex_corridor_in_turn(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path, ("a", 7.8, Y), ("b", 15.2, Y))
    try:
        added = await add_zone(w, "corridor_a", "corridor", LONG)
        assert added["success"], added
        await w.until(lambda: "corridor_a" in zones(w), 5, "the zone on /fleet/zones")
        assert zones(w)["corridor_a"]["kind"] == "corridor"
        assert zones(w)["corridor_a"]["capacity"] == 1
        east, west = await asyncio.gather(dispatch(w, target=pose(18.0, Y), robot="a"),
                                          dispatch(w, target=pose(5.0, Y), robot="b"))
        assert east["robot"] == "a" and west["robot"] == "b", (east, west)
        await w.until(lambda: any("waiting for zone corridor_a" in (task(w, t) or {}).get(
            "message", "") for t in (east["task"], west["task"])), 20,
            "one robot waiting for the zone")
        await w.until(lambda: any(  # issue 46: listed waiting for it, not idle
            r["state"] == "waiting" and r["message"].startswith("waiting for zone corridor_a")
            for r in robots(w).values()), 5, "the robot listed waiting for the zone")
        await w.until(lambda: zones(w)["corridor_a"]["waiting"], 5, "the waiter listed")
        listed = zones(w)["corridor_a"]
        assert len(listed["holders"]) == 1 and listed["waiting"] != listed["holders"]
        await w.until(lambda: all((task(w, t) or {}).get("state") == "succeeded"
                                  for t in (east["task"], west["task"])), 60, "both arriving")
        assert never_two_inside(w, LONG) >= 2
        assert all(len(z["holders"]) <= 1 for _, m in w.messages["/fleet/zones"]
                   for z in m["zones"])
        final = robots(w)
        assert math.hypot(final["a"]["pose"]["position"]["x"] - 18.0,
                          final["a"]["pose"]["position"]["y"] - Y) < 0.3
        assert zones(w)["corridor_a"]["holders"] == []
    finally:
        await w.close()


async def test_three_robots_crossing_two_zones_never_deadlock(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path, ("a", 6.0, Y), ("b", 17.5, Y),
                             ("c", 15.8, 4.5))
    try:
        for name, kind, points in (("corridor_a", "corridor", CORRIDOR),
                                   ("door_e", "door", DOOR)):
            assert (await add_zone(w, name, kind, points))["success"]
        jobs = await asyncio.gather(*(send(w, x, y, robot) for x, y, robot in (
            (18.5, Y, "a"),  # east through the corridor
            (6.5, Y, "b"),  # west through the corridor
            (8.0, 8.3, "c"))))  # north through the door, then west through the corridor
        assert [j["robot"] for j in jobs] == ["a", "b", "c"], jobs
        await w.until(lambda: all((task(w, j["task"]) or {}).get("state") in (
            "succeeded", "failed") for j in jobs), 90, "every task ending")
        assert [task(w, j["task"])["state"] for j in jobs] == ["succeeded"] * 3, [
            task(w, j["task"]) for j in jobs]
        assert never_two_inside(w, CORRIDOR) >= 2
        never_two_inside(w, DOOR)
        waited = {t["message"] for _, m in w.messages["/fleet/tasks"] for t in m["tasks"]}
        assert any("waiting for zone" in text for text in waited), waited
        assert all(not z["holders"] and not z["waiting"] for z in zones(w).values())
    finally:
        await w.close()


async def test_a_robot_going_to_charge_waits_for_a_zone_another_robot_stands_in(make_server,
                                                                              tmp_path):
    _server, w = await start(make_server, tmp_path, ("a", 1.0, 8.3), ("b", 3.5, 7.0))
    try:
        assert (await add_zone(w, "lobby", "door", LOBBY_DOOR))["success"]
        await w.until(lambda: zones(w)["lobby"]["holders"] == ["b"], 5,
                      "b holding the zone it stands in")
        low = await w.call("/a/sim/set_battery", {"percent": 20.0})
        assert low["values"]["success"], low
        def charge() -> dict:
            latest = w.latest("/fleet/tasks") or {"tasks": []}
            return next((t for t in latest["tasks"] if t["kind"] == "charge"), {})

        await w.until(lambda: "waiting for zone lobby (held by b)" in charge().get(
            "message", ""), 20, "a on its way to its dock waiting for the zone")
        await w.until(lambda: zones(w)["lobby"]["waiting"] == ["a"], 5, "a listed waiting")
        a = robots(w)["a"]["pose"]["position"]
        assert not inside(LOBBY_DOOR, a["x"], a["y"])  # stopped before the zone
        away = await dispatch(w, target=pose(8.0, Y), robot="b")
        assert away["robot"] == "b", away
        await w.until(lambda: any(f"{word} zone lobby" in charge().get("message", "")
                                  for word in ("crossing", "past")), 20,
                      "a going on once b is out")
        assert never_two_inside(w, LOBBY_DOOR) >= 1
    finally:
        await w.close()


async def test_bad_zones_are_refused_and_stops_in_a_zone_too(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path, ("a", 6.0, Y))
    try:
        assert (await add_zone(w, "corridor_a", "corridor", CORRIDOR))["success"]
        square = [(1.0, 1.0), (2.0, 1.0), (2.0, 2.0), (1.0, 2.0)]
        for request, field in (
                ({"name": "", "polygon": polygon(square)}, "name"),
                ({"name": "corridor_a", "polygon": polygon(square)}, "name"),
                ({"name": "x y", "polygon": polygon(square)}, "name"),
                ({"name": "two", "polygon": polygon(square[:2])}, "polygon.points"),
                ({"name": "bow", "polygon": polygon([(1, 1), (2, 2), (2, 1), (1, 2)])},
                 "polygon.points"),
                ({"name": "far", "polygon": polygon([(1, 1), (90, 1), (90, 2)])},
                 "polygon.points[1]"),
                ({"name": "flat", "polygon": polygon([(1, 1), (2, 1), (3, 1)])},
                 "polygon.points"),
                ({"name": "nan", "polygon": {"points": [{"x": "NaN", "y": 1, "z": 0}] * 3}},
                 "polygon.points[0]"),
                ({"name": "k", "kind": "x" * 40, "polygon": polygon(square)}, "kind")):
            reply = await w.call("/fleet/zone_add", {"kind": "", **request})
            values = reply["values"]
            if reply["result"]:  # refused by the fleet
                assert not values["success"], (request, reply)
                values = values["message"]
            assert field in values, (field, reply)  # or by the message's type check
        inner = await dispatch(w, target=pose(11.5, Y), robot="a")
        assert not inner["accepted"] and "corridor_a" in inner["message"], inner
        listed = (await w.call("/fleet/zone_list"))["values"]["zones"]
        assert [z["name"] for z in listed] == ["corridor_a"]
        gone = await w.call("/fleet/zone_remove", {"name": "nope"})
        assert not gone["values"]["success"] and "nope" in gone["values"]["message"]
        assert (await add_zone(w, "door_e", "door", DOOR))["success"]
        assert (await w.call("/fleet/zone_remove", {"name": "door_e"}))["values"]["success"]
    finally:
        await w.close()


def report(name: str, state: str, x: float, y: float) -> dict:
    return {"name": name, "pose": pose(x, y), "state": state, "battery": 90.0, "task": 0,
            "message": "", "in_service": True, "dock": pose(0, 0), "has_dock": False}


async def test_an_offline_robot_holds_its_zone_until_an_operator_releases_it(make_server,
                                                                           tmp_path):
    """Issue 52, item 4: a robot that goes offline standing in a zone (its report then says
    (0, 0)) keeps holding it where it was last seen; an operator's release lets it go, with a
    warning, and only an offline holder can be released so."""
    _server, w = await start(make_server, tmp_path, ("a", 4.0, Y))
    try:
        assert (await add_zone(w, "door", "door", DOOR))["success"]
        await w.publish("/fleet/members", report("ghost", "idle", 14.5, 6.5),
                        "hitrobot_msgs/FleetRobot")
        await w.until(lambda: zones(w)["door"]["holders"] == ["ghost"], 5, "ghost holding it")
        await w.publish("/fleet/members", report("ghost", "offline", 0.0, 0.0))
        await w.until(lambda: robots(w).get("ghost", {}).get("state") == "offline", 5,
                      "ghost listed offline")
        assert zones(w)["door"]["holders"] == ["ghost"]  # still where it was last seen
        released = (await w.call("/fleet/zone_release", {"name": "door"}))["values"]
        assert released["success"] and "ghost (offline)" in released["message"], released
        await w.until(lambda: zones(w)["door"]["holders"] == [], 5, "the zone free")
        again = (await w.call("/fleet/zone_release", {"name": "door"}))["values"]
        assert not again["success"] and "no offline robot" in again["message"]
    finally:
        await w.close()

"""The fleet node with two and three simulated robots in one server: /fleet/robots, dispatch
to the nearer idle robot, the queue, cancel, refusals."""

from __future__ import annotations

import math

from hitrobot_server.robot.options import RobotEntry
from tests.helpers import Watcher

Y = 8.0  # the office corridor
POI_T = "map_messages/PointOfInterest"


def pose(x: float, y: float) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}


async def fleet(make_server, tmp_path, *robots: tuple[str, float, float], speed: float = 3.0):
    server = await make_server(
        robots=tuple(RobotEntry(n, "sim", (x, y, 0.0)) for n, x, y in robots),
        map_dir=str(tmp_path), sim_speed=speed)
    w = await Watcher.open(server.port)
    for topic in ("/fleet/robots", "/fleet/tasks", "/map_manager/pois"):
        await w.subscribe(topic)
    await w.until(lambda: len(idle(w)) == len(robots), 15, "every robot idle")
    return server, w


def robots(w: Watcher) -> dict[str, dict]:
    latest = w.latest("/fleet/robots")
    return {r["name"]: r for r in latest["robots"]} if latest else {}


def idle(w: Watcher) -> list[str]:
    return sorted(n for n, r in robots(w).items() if r["state"] == "idle")


def task(w: Watcher, task_id: int) -> dict | None:
    latest = w.latest("/fleet/tasks")
    return next((t for t in latest["tasks"] if t["id"] == task_id), None) if latest else None


def at(w: Watcher, name: str, x: float, y: float, tol: float = 0.3) -> bool:
    p = robots(w)[name]["pose"]["position"]
    return math.hypot(p["x"] - x, p["y"] - y) < tol


async def add_poi(w: Watcher, name: str, x: float, y: float) -> None:
    await w.publish("/map_manager/add_poi",
                    {"type": 100, "name": name, "remarks": "", "pose": pose(x, y)}, POI_T)
    await w.until(lambda: name in {p["name"] for p in (w.latest("/map_manager/pois") or
                                                       {"pois": []})["pois"]},
                  5, f"the POI {name}")


async def dispatch(w: Watcher, poi: str = "", target: dict | None = None, robot: str = ""):
    reply = await w.call("/fleet/dispatch",
                         {"poi": poi, "pose": target or pose(0, 0), "robot": robot}, timeout=15)
    assert reply["result"], reply
    return reply["values"]


async def test_robots_list_and_dispatch_picks_the_nearer_idle_robot(make_server, tmp_path):
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 12.0, Y))
    try:
        listed = robots(w)
        assert set(listed) == {"a", "b"}
        assert listed["a"]["battery"] > 0 and listed["a"]["task"] == 0
        assert at(w, "a", 4.0, Y, 0.1) and at(w, "b", 12.0, Y, 0.1)
        first = len(w.messages["/fleet/robots"])
        await w.until(lambda: len(w.messages["/fleet/robots"]) >= first + 2, 3,
                      "/fleet/robots at 2 Hz")

        await add_poi(w, "east", 14.0, Y)
        got = await dispatch(w, "east")
        assert got["accepted"] and got["robot"] == "b", got  # b is 2 m away, a 10 m
        await w.until(lambda: robots(w)["b"]["task"] == got["task"], 5, "b running the task")
        await w.until(lambda: (task(w, got["task"]) or {}).get("state") == "succeeded", 30,
                      "b arriving")
        await w.until(lambda: at(w, "b", 14.0, Y), 3, "b listed at the POI")
        assert all(math.hypot(r["pose"]["position"]["x"] - 4.0, r["pose"]["position"]["y"] - Y)
                   < 0.05 for _, m in w.messages["/fleet/robots"] for r in m["robots"]
                   if r["name"] == "a")  # only b moved

        near_a = await dispatch(w, target=pose(6.0, Y))
        assert near_a["robot"] == "a", near_a
        await w.until(lambda: (task(w, near_a["task"]) or {}).get("state") == "succeeded", 30,
                      "a arriving")
    finally:
        await w.close()


async def test_tasks_queue_when_every_robot_is_busy_and_cancel(make_server, tmp_path):
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 6.0, Y), speed=2.0)
    try:
        one = await dispatch(w, target=pose(16.0, Y), robot="a")
        two = await dispatch(w, target=pose(18.0, Y), robot="b")
        assert one["robot"] == "a" and two["robot"] == "b"
        three = await dispatch(w, target=pose(2.0, Y))
        assert three["accepted"] and three["robot"] == "" and "queued" in three["message"]
        four = await dispatch(w, target=pose(3.0, Y))
        assert (task(w, four["task"]) or {}).get("state") == "queued"
        cancelled = await w.call("/fleet/cancel", {"task": four["task"]})
        assert cancelled["values"]["success"], cancelled
        again = await w.call("/fleet/cancel", {"task": four["task"]})
        assert not again["values"]["success"] and "already cancelled" in again["values"]["message"]
        # the first robot to finish takes the queued task
        await w.until(lambda: (task(w, three["task"]) or {}).get("state") == "running", 60,
                      "the queued task running")
        runner = task(w, three["task"])["assigned"]
        assert runner in ("a", "b")
        assert task(w, four["task"])["state"] == "cancelled"  # never handed out
        stopped = await w.call("/fleet/cancel", {"task": three["task"]})
        assert stopped["values"]["success"]
        await w.until(lambda: robots(w)[runner]["state"] == "idle", 10, "the runner stopping")
    finally:
        await w.close()


async def test_bad_dispatches_are_refused(make_server, tmp_path):
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 12.0, Y))
    try:
        await w.until(lambda: w.latest("/fleet/tasks") is not None, 5, "the latched task list")
        before = w.latest("/fleet/tasks")["tasks"]
        for args, needle in ((dict(poi="nowhere"), "unknown POI 'nowhere'"),
                             (dict(poi="", robot="zed"), "unknown robot 'zed'")):
            got = await dispatch(w, **args)
            assert not got["accepted"] and needle in got["message"] and got["task"] == 0, got
        bad = pose(float("nan"), Y)
        got = await dispatch(w, target=bad)
        assert not got["accepted"] and "pose.position" in got["message"]
        outside = await dispatch(w, target=pose(-0.4, -0.4))  # beyond the site map's edge
        assert not outside["accepted"] and "off the map" in outside["message"], outside
        inside = await dispatch(w, target=pose(10.0, 0.1))  # in the outer wall
        assert not inside["accepted"] and inside["task"] == 0, inside  # refused, with why:
        assert inside["message"] == "(10, 0.1) is on an obstacle", inside  # the POIs' rule
        assert w.latest("/fleet/tasks")["tasks"][:len(before)] == before
    finally:
        await w.close()


async def test_three_robots_a_failed_task_goes_to_another_robot(make_server, tmp_path):
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 8.0, Y),
                             ("c", 16.0, Y), speed=1.0)
    try:
        assert set(robots(w)) == {"a", "b", "c"}
        got = await dispatch(w, target=pose(11.0, Y))
        assert got["robot"] == "b", got
        await w.until(lambda: robots(w)["b"]["state"] == "moving", 10, "b moving")
        # b sits down mid-way: its goal fails, and the task is offered to the next robot
        sat = await w.call("/b/sit_down")
        assert sat["values"]["success"], sat
        await w.until(lambda: "b" in (task(w, got["task"]) or {}).get("tried", []), 15,
                      "the failure reported")
        await w.until(lambda: (task(w, got["task"]) or {}).get("state") == "succeeded", 40,
                      "another robot finishing it")
        assert task(w, got["task"])["assigned"] == "c"  # the nearer of the other two
    finally:
        await w.close()


async def test_dispatch_is_refused_when_every_robot_is_offline(make_server, tmp_path):
    import socket

    with socket.socket() as s:  # a loopback port nothing listens on: the robots never answer
        s.bind(("127.0.0.1", 0))
        url = f"http://127.0.0.1:{s.getsockname()[1]}"
    server = await make_server(robots=(RobotEntry("a", url), RobotEntry("b", url)),
                               map_dir=str(tmp_path))
    w = await Watcher.open(server.port)
    try:
        await w.subscribe("/fleet/robots")
        await w.until(lambda: {n: r["state"] for n, r in robots(w).items()} == {
            "a": "offline", "b": "offline"}, 10, "both robots listed offline")
        got = await dispatch(w, target=pose(5.0, Y))
        assert not got["accepted"] and got["message"] == "every robot is offline", got
        named = await dispatch(w, target=pose(5.0, Y), robot="a")
        assert not named["accepted"] and "offline" in named["message"]
    finally:
        await w.close()

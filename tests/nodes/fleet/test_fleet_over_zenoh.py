"""Two real servers joined over Zenoh, one named robot each: one /fleet/robots on both, and a
dispatch from one server drives the other server's robot."""

from __future__ import annotations

import math

from tests.bus.test_zenoh_scale_out import free_port, zenoh_server
from tests.helpers import Watcher

Y = 8.0


def pose(x: float, y: float) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}


async def close_all(watchers, servers) -> None:
    """The watchers, then the servers (the last started first); None for one never made."""
    for w in watchers:
        if w is not None:
            await w.close()
    for server in servers:
        if server is not None:
            server.stop()


def names(w: Watcher) -> set[str]:
    latest = w.latest("/fleet/robots")
    return {r["name"] for r in latest["robots"] if r["state"] == "idle"} if latest else set()


async def test_two_servers_one_fleet(tmp_path):
    port = free_port()
    one = zenoh_server(listen=port, robot="a=sim@4,8",
                       extra=("--map-dir", str(tmp_path / "one"), "--sim-speed", "2"))
    two = None
    w1 = w2 = None
    try:
        two = zenoh_server(connect=port, robot="b=sim@12,8",
                           extra=("--map-dir", str(tmp_path / "two"), "--sim-speed", "2"))
        w1, w2 = await Watcher.open(one.port), await Watcher.open(two.port)
        for w in (w1, w2):
            await w.subscribe("/fleet/robots")
            await w.subscribe("/fleet/tasks")
        await w1.until(lambda: names(w1) == {"a", "b"}, 30, "both robots on server one")
        await w2.until(lambda: names(w2) == {"a", "b"}, 30, "both robots on server two")

        reply = await w1.call("/fleet/dispatch", {"poi": "", "pose": pose(13.0, Y), "robot": ""},
                              timeout=20)
        got = reply["values"]
        assert got["accepted"] and got["robot"] == "b", got  # the nearer one, on the other server

        def finished() -> bool:
            tasks = (w1.latest("/fleet/tasks") or {"tasks": []})["tasks"]
            return any(t["id"] == got["task"] and t["state"] == "succeeded" for t in tasks)

        await w1.until(finished, 40, "b arriving, seen from server one")

        def b_at_goal() -> bool:
            robots = {r["name"]: r for r in (w1.latest("/fleet/robots") or {"robots": []})[
                "robots"]}
            p = robots.get("b", {}).get("pose", {}).get("position")
            return p is not None and math.hypot(p["x"] - 13.0, p["y"] - Y) < 0.3

        await w1.until(b_at_goal, 10, "b listed at its goal")
        refused = (await w2.call("/fleet/dispatch",
                                 {"poi": "", "pose": pose(5.0, Y), "robot": "zed"}))["values"]
        assert not refused["accepted"] and "unknown robot 'zed'" in refused["message"]
    finally:
        await close_all((w1, w2), (two, one))

"""The mutex zones of a real ``hitrobot-server`` process survive kill -9: the zone comes back
from the state folder as it was drawn, and who holds it is found again from the robots' poses
(a robot standing in it holds it)."""

from __future__ import annotations

from ..helpers import ServerProcess, Watcher
from ..nodes.test_fleet_zones import polygon

OVER_B = [(11.0, 7.2), (13.0, 7.2), (13.0, 8.8), (11.0, 8.8)]  # robot b stands in it


async def zones_watcher(port: int) -> Watcher:
    w = await Watcher.open(port)
    for topic in ("/fleet/robots", "/fleet/zones"):
        await w.subscribe(topic)
    await w.until(lambda: sum(r["state"] == "idle" for r in (
        w.latest("/fleet/robots") or {"robots": []})["robots"]) == 2, 30, "both robots idle")
    return w


def zone(w: Watcher, name: str) -> dict | None:
    latest = w.latest("/fleet/zones") or {"zones": []}
    return next((z for z in latest["zones"] if z["name"] == name), None)


async def test_zones_survive_kill_9(tmp_path):
    args = ("--robot", "b=sim@12,8", "--sim-speed", "4", "--state-dir", str(tmp_path / "state"),
            "--map-dir", str(tmp_path / "m"))
    server = ServerProcess(*args, robot="a=sim@6,8")
    try:
        w = await zones_watcher(server.port)
        added = await w.call("/fleet/zone_add", {"name": "door_b", "kind": "door",
                                                 "polygon": polygon(OVER_B)}, timeout=30)
        assert added["values"]["success"], added
        await w.until(lambda: (zone(w, "door_b") or {}).get("holders") == ["b"], 5,
                      "b holding the zone it stands in")
        await w.close()
        server.kill()  # the add was answered once on disk
    finally:
        server.stop()
    server = ServerProcess(*args, robot="a=sim@6,8")
    try:
        w = await zones_watcher(server.port)
        await w.until(lambda: (zone(w, "door_b") or {}).get("holders") == ["b"], 5,
                      "the zone back, held by b again")
        back = zone(w, "door_b")
        assert back["kind"] == "door" and back["waiting"] == []
        assert [(p["x"], p["y"]) for p in back["polygon"]["points"]] == OVER_B
        await w.close()
    finally:
        server.stop()

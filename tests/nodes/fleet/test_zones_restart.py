"""The mutex zones of a real ``hitrobot-server`` process survive kill -9: the zone comes back
from the state folder as it was drawn, and who holds it is found again from the robots' poses
(a robot standing in it holds it); a thousand adds sent back to back keep the bound of zones,
and every acknowledged one comes back."""

from __future__ import annotations

import asyncio

import pytest

from hitrobot_server.nodes.fleet.zones import MAX_ZONES
from tests.helpers import ServerProcess, Watcher, WsClient
from tests.nodes.fleet.test_zones import polygon
from tests.witness import RoundTrips

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


BURST = 1000
"""zone_add requests sent back to back (the issue's attack), half on each of two connections."""


def small_square(i: int) -> dict:
    """A 0.2 m square of its own, on the site map (refused ones are refused by the bound)."""
    x, y = 1.0 + (i % 30) * 0.5, 1.0 + (i // 30) * 0.3
    return polygon([(x, y), (x + 0.2, y), (x + 0.2, y + 0.2), (x, y + 0.2)])


async def pipelined_adds(port: int, first: int, count: int) -> dict[str, bool]:
    """``count`` zone_add calls written back to back on one connection, before any answer is
    read; each zone's name → whether its add was acknowledged."""
    client = await WsClient.open(port)
    try:
        for i in range(first, first + count):
            await client.send({"op": "call_service", "id": f"z{i}", "service": "/fleet/zone_add",
                               "args": {"name": f"z{i}", "kind": "door",
                                        "polygon": small_square(i)}})
        answers = {}
        for _ in range(count):
            reply = await client.expect(op="service_response", timeout=60)
            values = reply["values"]
            assert values["success"] or values["message"] == (
                f"{MAX_ZONES} zones already; remove one first"), values
            answers[reply["id"]] = values["success"]
        return answers
    finally:
        await client.close()


@pytest.mark.serial  # the witness's bound: run alone (tests/run.py)
async def test_pipelined_zone_adds_keep_the_bound_and_every_acknowledged_one(tmp_path):
    args = ("--state-dir", str(tmp_path / "state"), "--map-dir", str(tmp_path / "m"))
    server = ServerProcess(*args, robot="a=sim@6,8")
    try:
        w = await Watcher.open(server.port)
        await w.subscribe("/fleet/robots")
        await w.until(lambda: (w.latest("/fleet/robots") or {}).get("robots"), 30, "robot a")
        witness = await RoundTrips.open(server.port)
        halves = await asyncio.gather(pipelined_adds(server.port, 0, BURST // 2),
                                      pipelined_adds(server.port, BURST // 2, BURST // 2))
        worst = await witness.stop()
        kept = {name for half in halves for name, ok in half.items() if ok}
        assert len(kept) == MAX_ZONES, len(kept)  # exactly the bound, the rest refused
        listed = (await w.call("/fleet/zone_list", timeout=30))["values"]["zones"]
        assert {z["name"] for z in listed} == kept
        assert worst <= 0.5, witness.times
        await w.close()
        server.kill()  # every add was answered once on disk
    finally:
        server.stop()
    server = ServerProcess(*args, robot="a=sim@6,8")
    try:
        w = await Watcher.open(server.port)
        listed = (await w.call("/fleet/zone_list", timeout=30))["values"]["zones"]
        assert {z["name"] for z in listed} == kept  # each acknowledged zone back, none other
        await w.close()
    finally:
        server.stop()

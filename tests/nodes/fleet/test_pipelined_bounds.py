"""The fleet's bounds under pipelined requests, against the real server (issue 52, item 1):
requests written back to back on one connection, before any answer is read, pass a bound no
more than one at a time would. Zones (with kill -9):
tests/nodes/fleet/test_zones_restart.py."""

from __future__ import annotations

import time

import pytest

from hitrobot_server.nodes.fleet.member import PERIOD
from hitrobot_server.nodes.fleet.schedules import MAX_SCHEDULES
from tests.helpers import WsClient
from tests.nodes.fleet.test_node import Y, add_poi
from tests.nodes.fleet.test_operations import HeldClock, clocked, open_watcher
from tests.witness import RoundTrips

SCHEDULES = 150
"""schedule_add requests sent back to back (the issue's burst; the bound is 100)."""


async def pipelined(port: int, service: str, requests: list[dict]) -> list[dict]:
    """``requests`` to ``service`` written back to back on one connection, then every answer
    read (in the order they come)."""
    client = await WsClient.open(port)
    try:
        for i, args in enumerate(requests):
            await client.send({"op": "call_service", "id": f"r{i}", "service": service,
                               "args": args})
        return [(await client.expect(op="service_response", timeout=60))["values"]
                for _ in requests]
    finally:
        await client.close()


def dispatched(w) -> set[int]:
    """Every task id /fleet/tasks has listed so far."""
    return {t["id"] for _, msg in w.messages.get("/fleet/tasks", []) for t in msg["tasks"]}


@pytest.mark.serial  # the witness's and the list's bounds: run alone (tests/run.py)
async def test_pipelined_schedule_adds_keep_the_bound_and_firing_holds_up_no_list(tmp_path):
    day = 1_800_000_000.0
    clock = HeldClock(day)
    server = await clocked(tmp_path, tmp_path / "state", clock)
    w = await open_watcher(server)
    try:
        for i in range(4):
            await add_poi(w, f"desk{i}", 6.0 + i, Y)
        # each add reads its POI from the map manager: an await between its check and its add
        answers = await pipelined(server.port, "/fleet/schedule_add", [
            {"when": "every 1 h", "poi": f"desk{i % 4}", "robot": ""} for i in range(SCHEDULES)])
        kept = [a for a in answers if a["success"]]
        assert len(kept) == MAX_SCHEDULES, len(kept)
        assert all(a["message"] == f"{MAX_SCHEDULES} schedules already; remove one first"
                   for a in answers if not a["success"])
        listed = (await w.call("/fleet/schedule_list"))["values"]["schedules"]
        assert sorted(s["id"] for s in listed) == sorted(a["id"] for a in kept)
        # every slot due at once: they dispatch beside the 2 Hz list, which keeps its pace
        witness = await RoundTrips.open(server.port)
        listed_before = len(w.messages["/fleet/robots"])
        began = time.monotonic()
        clock.now = day + 3600
        await w.until(lambda: len(dispatched(w)) == MAX_SCHEDULES, 60, "every slot dispatched")
        worst = await witness.stop()
        stamps = [t for t, _ in w.messages["/fleet/robots"][listed_before:]]
        gaps = [b - a for a, b in zip([began, *stamps], stamps, strict=False)]
        assert max(gaps) < 2 * PERIOD, gaps
        assert worst <= 0.5, witness.times
    finally:
        await w.close()
        await server.stop()

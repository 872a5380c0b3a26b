"""The acknowledgement table (nodes/ground/acks.py) against a real server: every ``/fleet/*``
service and every map-manager request is in it, a name missing from it is refused where it is
offered, and a refusal is answered at once while a change waits for ``keeping``."""

from __future__ import annotations

import asyncio

import pytest

from hitrobot_server.nodes.ground.acks import ACKS, KEPT
from hitrobot_server.nodes.ground.memory import acknowledged, kept, waits
from tests.nodes.fleet.test_node import Y, fleet

CHANGES = ("/fleet/dispatch", "/fleet/cancel", "/fleet/pause", "/fleet/resume",
           "/fleet/set_in_service", "/fleet/schedule_add", "/fleet/schedule_remove",
           "/fleet/zone_add", "/fleet/zone_remove", "add_poi", "modify_poi", "delete_poi",
           "map_layers", "modify_map", "load_map")


async def test_every_fleet_service_and_map_manager_request_is_in_the_table(make_server,
                                                                            tmp_path):
    server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y))
    try:
        fleet_services = {n for n in server.bus.services if n.startswith("/fleet/")}
        assert fleet_services and fleet_services <= set(ACKS), fleet_services - set(ACKS)
        requests = {t.name.removeprefix("/map_manager/") for t in server.bus.topics.values()
                    if any(node == "/map_manager" for node, _ in t.subscribers.values())
                    and (t.name.startswith("/map_manager/") or t.name == "/map")}
        assert {"add_poi", "modify_map", "load_map", "/map"} <= requests
        assert requests <= set(ACKS), requests - set(ACKS)
        assert {n for n, rule in ACKS.items() if rule == KEPT} == set(CHANGES)
    finally:
        await w.close()


async def test_the_wrapper_waits_for_a_change_and_not_for_a_refusal_or_a_read():
    gate, entered = asyncio.Event(), asyncio.Event()
    waited: list[str] = []

    async def keeping() -> str:
        waited.append("kept")
        entered.set()
        await gate.wait()
        return " (copied to 0 of the 1 other servers only)"

    async def handler(request: dict) -> dict:
        return {"success": request["ok"], "message": "done"}

    cancel = acknowledged("/fleet/cancel", handler, keeping)
    assert await cancel({"ok": False}) == {"success": False, "message": "done"}
    assert waited == []
    answer = asyncio.ensure_future(cancel({"ok": True}))
    await asyncio.wait_for(entered.wait(), 5)  # the handler answered; its reply waits
    assert not answer.done() and waited == ["kept"]
    gate.set()
    assert (await asyncio.wait_for(answer, 5))["message"] == \
        "done (copied to 0 of the 1 other servers only)"
    assert acknowledged("/fleet/history", handler, keeping) is handler
    assert await kept("get_pois", keeping) == ""
    with pytest.raises(ValueError, match="not in the acknowledgement table"):
        waits("/fleet/new_change")
    with pytest.raises(ValueError, match="not in the acknowledgement table"):
        acknowledged("/fleet/new_change", handler, keeping)

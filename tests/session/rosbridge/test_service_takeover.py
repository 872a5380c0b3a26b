"""A client cannot take over a server node's service; a client may replace another client's
service, and when it leaves the previous provider answers again."""

from __future__ import annotations

import asyncio

from tests.sansio import SessionClient
from tests.witness import Witness


async def serve(client: SessionClient, name: str, tag: str, count: int) -> None:
    """Answer ``count`` calls of ``name`` with ``tag``."""
    for _ in range(count):
        call = await client.expect(op="call_service", service=name, timeout=10)
        await client.send({"op": "service_response", "id": call["id"], "service": name,
                           "result": True, "values": {"success": True, "message": tag}})


async def test_node_service_cannot_be_taken_over(hub):
    witness = await Witness.on(hub.open(), hub.open())
    bad = hub.open()
    for op_id, service, type_name in (
        ("a1", "/rosapi/get_time", "rosapi/GetTime"),
        ("a2", "/rosapi/topics", "rosapi/Topics"),
    ):
        await bad.send({"op": "advertise_service", "id": op_id, "service": service,
                        "type": type_name})
        status = await bad.expect(op="status", id=op_id)
        assert status["level"] == "error"
        assert "provided by the server" in status["msg"] and service in status["msg"]
    await bad.send({"op": "advertise_action", "id": "a3", "action": "/rosapi/get_time",
                    "type": "nav2_msgs/FollowPath"})  # no node action there: allowed
    await witness.check()  # /rosapi/get_time still answered by rosapi
    assert hub.bus.service("/rosapi/get_time").client is False
    await bad.close()
    await witness.close()


async def test_client_replaces_client_and_the_previous_provider_comes_back(hub):
    witness = await Witness.on(hub.open(), hub.open())
    first, second = hub.open(), hub.open()
    caller = hub.open()
    for client, op_id in ((first, "f"), (second, "s")):
        await client.send({"op": "set_level", "level": "info"})
        await client.send({"op": "advertise_service", "id": op_id, "service": "/shared",
                           "type": "std_srvs/Trigger"})
        assert (await client.expect(op="status", id=op_id))["level"] == "info"
    # the later advertiser answers
    answered = asyncio.ensure_future(serve(second, "/shared", "second", 1))
    reply = await caller.call("/shared")
    assert reply["values"]["message"] == "second"
    await answered
    # it leaves: the earlier one answers again, without re-advertising
    provider = hub.bus.service("/shared").node
    await second.close()
    assert hub.bus.service("/shared").node != provider  # the close is handled at once
    answered = asyncio.ensure_future(serve(first, "/shared", "first", 1))
    reply = await caller.call("/shared", timeout=10)
    assert reply["result"] is True and reply["values"]["message"] == "first"
    await answered
    await first.close()
    reply = await caller.call("/shared")
    assert reply["result"] is False and "does not exist" in reply["values"]
    await witness.check()
    await caller.close()
    await witness.close()

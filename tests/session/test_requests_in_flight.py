"""Pending calls are capped per client (``--max-requests-in-flight``): calls to a provider that
never answers are refused beyond the cap with a status naming it, and everything a pending call
held is freed when the caller or the provider leaves. Real sockets; a witness client keeps being
served meanwhile."""

from __future__ import annotations

import time

from tests.helpers import WsClient, silent_provider
from tests.witness import Witness

LIMIT = 20
EXTRA = 5


async def nodes(client: WsClient) -> set[str]:
    reply = await client.call("/rosapi/nodes")
    return set(reply["values"]["nodes"])


async def until_nodes(client: WsClient, expected: set[str], timeout: float = 5.0) -> None:
    """Wait (bounded, by round trips) until the bus lists exactly ``expected`` nodes."""
    deadline = time.monotonic() + timeout
    while (got := await nodes(client)) != expected:
        assert time.monotonic() < deadline, f"nodes {got}, expected {expected}"


async def test_calls_beyond_the_cap_are_refused_and_freed_when_the_caller_leaves(make_server):
    server = await make_server(max_requests_in_flight=LIMIT)
    witness = await Witness.open(server.port)
    provider = await silent_provider(server.port)
    before = await nodes(witness.sub)
    caller = await WsClient.open(server.port)
    for i in range(LIMIT + EXTRA):
        await caller.send({"op": "call_service", "id": f"c{i}", "service": "/mute"})
    requests = [await provider.expect(op="call_service") for _ in range(LIMIT)]
    await provider.expect_none(op="call_service")
    for i in range(LIMIT, LIMIT + EXTRA):
        reply = await caller.expect(op="service_response", id=f"c{i}")
        assert reply["result"] is False
        assert "too many requests in flight" in reply["values"]
        assert f"{LIMIT} service calls" in reply["values"]
        status = await caller.expect(op="status", id=f"c{i}")
        assert status["level"] == "error" and "too many requests in flight" in status["msg"]
    await witness.check()

    # the caller leaves: its calls are forgotten by the provider's side too
    await caller.close()
    await until_nodes(witness.sub, before)
    for request in requests:
        await provider.send({"op": "service_response", "id": request["id"],
                             "service": "/mute", "values": {"success": True, "message": ""},
                             "result": True})
        status = await provider.expect(op="status", id=request["id"])
        assert "no pending request" in status["msg"]

    # a new caller gets the whole cap again, and the answers
    again = await WsClient.open(server.port)
    for i in range(LIMIT):
        await again.send({"op": "call_service", "id": f"a{i}", "service": "/mute"})
    for i in range(LIMIT):
        request = await provider.expect(op="call_service")
        await provider.send({"op": "service_response", "id": request["id"], "service": "/mute",
                             "values": {"success": True, "message": f"m{i}"}, "result": True})
    for i in range(LIMIT):
        reply = await again.expect(op="service_response", id=f"a{i}")
        assert reply["result"] is True
    await witness.check()
    await again.close()
    await provider.close()
    await witness.close()


async def test_pending_calls_fail_and_free_the_cap_when_the_provider_leaves(make_server):
    server = await make_server(max_requests_in_flight=LIMIT)
    provider = await silent_provider(server.port)
    caller = await WsClient.open(server.port)
    for i in range(LIMIT):
        await caller.send({"op": "call_service", "id": f"c{i}", "service": "/mute"})
    for _ in range(LIMIT):
        await provider.expect(op="call_service")
    await provider.close()
    for i in range(LIMIT):
        reply = await caller.expect(op="service_response", id=f"c{i}")
        assert reply["result"] is False and "disconnected" in reply["values"]
    # the cap is free again: a call to a live service is answered
    assert (await caller.call("/rosapi/get_time"))["result"] is True
    await caller.close()


async def test_action_goals_beyond_the_cap_are_refused(make_server):
    server = await make_server(max_requests_in_flight=3)
    provider = await WsClient.open(server.port)
    await provider.send({"op": "set_level", "level": "info"})
    await provider.send({"op": "advertise_action", "id": "adv", "action": "/nav",
                         "type": "nav2_msgs/NavigateToPose"})
    await provider.expect(op="status", id="adv")
    caller = await WsClient.open(server.port)
    goal = {"op": "send_action_goal", "action": "/nav", "action_type": "nav2_msgs/NavigateToPose",
            "args": {}}
    for i in range(4):
        await caller.send({**goal, "id": f"g{i}"})
    handed = [await provider.expect(op="send_action_goal") for _ in range(3)]
    refused = await caller.expect(op="action_result", id="g3")
    assert refused["result"] is False and "too many requests in flight" in refused["values"]
    assert "3 action goals" in refused["values"]
    # one goal finishes: the next is accepted
    await provider.send({"op": "action_result", "id": handed[0]["id"], "action": "/nav",
                         "values": {}, "status": 4, "result": True})
    assert (await caller.expect(op="action_result", id="g0"))["status"] == 4
    await caller.send({**goal, "id": "g4"})
    await provider.expect(op="send_action_goal")
    await caller.close()
    await provider.close()

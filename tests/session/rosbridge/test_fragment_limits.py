"""Incoming fragments: one server-wide memory limit, freed when a client closes, and expired
on --fragment-timeout by a timer, not by the next fragment."""

from __future__ import annotations

from hitrobot_server.protocol.fragment import FRAGMENT_OVERHEAD
from tests.helpers import WsClient
from tests.witness import Witness


def frag(op_id: str, data: str, num: int = 0, total: int = 2) -> dict:
    return {"op": "fragment", "id": op_id, "data": data, "num": num, "total": total}


async def test_server_wide_cap_and_a_closed_clients_fragments_are_freed(make_hub):
    cost = 1000 + FRAGMENT_OVERHEAD
    hub = await make_hub(max_frame_size=10 * cost, fragment_memory_limit=2 * cost)
    budget = hub.shared.fragments
    witness = await Witness.on(hub.open(), hub.open())
    hog, other = hub.open(), hub.open()
    await hog.send(frag("h1", "x" * 1000))
    await hog.send(frag("h2", "x" * 1000))
    assert (await hog.call("/rosapi/get_time"))["result"] is True  # both are held now
    assert budget.used == 2 * cost
    # each client is under its own limit, but together they are over the server's
    await other.send(frag("o1", "y" * 1000))
    status = await other.expect(op="status", id="o1")
    assert status["level"] == "error" and "all clients together" in status["msg"]
    await hog.close()
    assert budget.used == 0, "the closed client's fragments are freed"
    text = '{"op":"call_service","id":"joined","service":"/rosapi/get_time"}'
    await other.send(frag("o2", text[:20]))
    await other.send(frag("o2", text[20:], num=1))
    assert (await other.expect(op="service_response", id="joined"))["result"] is True
    assert budget.used == 0
    await witness.check()
    await other.close()
    await witness.close()


async def test_fragment_timeout_expires_on_a_timer(make_server):
    server = await make_server(fragment_timeout=0.2)
    witness = await Witness.open(server.port)
    c = await WsClient.open(server.port)
    await c.send({"op": "set_level", "level": "warning"})
    await c.send(frag("late", "z" * 500))
    # no other traffic from this client: the timer alone evicts the message
    status = await c.expect(op="status", id="late", timeout=5)
    assert status["level"] == "warning" and "--fragment-timeout" in status["msg"]
    assert server.shared.fragments.used == 0
    await c.send(frag("late", "{}", num=1))  # the rest alone does not complete anything
    assert (await c.call("/rosapi/get_time"))["result"] is True
    await witness.check()
    await c.close()
    await witness.close()

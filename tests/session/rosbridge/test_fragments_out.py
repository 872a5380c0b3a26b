"""Outgoing fragments are bounded: ``fragment_size`` below the floor is raised to it with a
warning, a message is cut into a bounded number of frames, and big ones are cut in the worker
pool. Real sockets; a witness client loses nothing meanwhile."""

from __future__ import annotations

import orjson

from hitrobot_server.protocol.fragment import MIN_FRAGMENT_SIZE
from tests.helpers import WsClient
from tests.witness import Witness

BIG = "m" * 300_000  # above the offload threshold: encoded and cut in the worker pool


async def fragments_of(client: WsClient) -> dict:
    """The op a complete run of fragments carries; every piece within the floor's size."""
    first = await client.expect(op="fragment", timeout=20)
    pieces = {first["num"]: first["data"]}
    while len(pieces) < first["total"]:
        op = await client.expect(op="fragment", id=first["id"], timeout=20)
        pieces[op["num"]] = op["data"]
    assert all(len(data) <= MIN_FRAGMENT_SIZE for data in pieces.values())
    text = "".join(pieces[i] for i in range(first["total"]))
    assert first["total"] == -(-len(text) // MIN_FRAGMENT_SIZE)
    return orjson.loads(text)


async def test_fragment_size_1_is_raised_to_the_floor_for_topics_and_replies(make_server):
    server = await make_server()
    witness = await Witness.open(server.port)
    sub = await WsClient.open(server.port)
    await sub.send({"op": "set_level", "level": "warning"})
    await sub.send({"op": "subscribe", "id": "s", "topic": "/big", "type": "std_msgs/String",
                    "fragment_size": 1})
    warning = await sub.expect(op="status", id="s")
    assert warning["level"] == "warning"
    assert "'fragment_size' 1" in warning["msg"] and str(MIN_FRAGMENT_SIZE) in warning["msg"]
    pub = await WsClient.open(server.port)
    await pub.send({"op": "advertise", "topic": "/big", "type": "std_msgs/String"})
    await pub.send({"op": "publish", "topic": "/big", "msg": {"data": BIG}})
    assert (await fragments_of(sub))["msg"]["data"] == BIG
    await witness.check()

    # a reply: a client's service answers with 300 kB, asked for in 1-character fragments
    provider = await WsClient.open(server.port)
    await provider.send({"op": "set_level", "level": "info"})
    await provider.send({"op": "advertise_service", "id": "adv", "service": "/big_reply",
                         "type": "std_srvs/Trigger"})
    await provider.expect(op="status", id="adv")
    await sub.send({"op": "call_service", "id": "c", "service": "/big_reply",
                    "fragment_size": 1})
    warning = await sub.expect(op="status", id="c")
    assert warning["level"] == "warning" and "'fragment_size' 1" in warning["msg"]
    request = await provider.expect(op="call_service")
    await provider.send({"op": "service_response", "id": request["id"], "service": "/big_reply",
                         "values": {"success": True, "message": BIG}, "result": True})
    reply = await fragments_of(sub)
    assert reply["id"] == "c" and reply["values"]["message"] == BIG
    await witness.check()
    for client in (sub, pub, provider):
        await client.close()
    await witness.close()

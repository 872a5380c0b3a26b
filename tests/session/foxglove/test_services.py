"""Service calls: advertised services, a call and its failure, an empty request, the bound on
calls waiting at once (``services.py``)."""

from __future__ import annotations

import asyncio
import struct

from hitrobot_server.nodes.base import Node
from hitrobot_server.session.foxglove.services import MAX_CALLS
from tests.session.foxglove.client import FoxClient


async def test_service_call_and_its_failure(hub):
    node = Node(hub.bus, "/srv")

    async def add(req: dict) -> dict:
        if req["a"] < 0:
            raise ValueError("negative")
        return {"sum": req["a"] + req["b"]}

    node.service("/fg/add", "rospy_tutorials/AddTwoInts", add)
    fox = FoxClient(hub)
    services = await fox.until(
        lambda m: isinstance(m, dict) and m.get("op") == "advertiseServices"
        and any(s["name"] == "/fg/add" for s in m["services"]), "advertiseServices")
    svc = next(s for s in services["services"] if s["name"] == "/fg/add")
    assert svc["request"]["schema"] == "int64 a\nint64 b\n"
    stype = hub.bus.types.srv("rospy_tutorials/AddTwoInts")

    def call(call_id: int, a: int, encoding: bytes = b"cdr") -> None:
        payload = fox.codec.encode({"a": a, "b": 2}, stype.request)
        fox.send(struct.pack("<BIII", 2, svc["id"], call_id, len(encoding)) + encoding + payload)

    call(5, 40)
    resp = await fox.until(lambda m: isinstance(m, tuple) and m[0] == 3, "service response")
    _, sid, call_id, n = struct.unpack_from("<BIII", resp[1])
    assert (sid, call_id) == (svc["id"], 5)
    assert fox.codec.decode(resp[1][13 + n:], stype.response) == {"sum": 42}
    call(6, -1)
    failure = await fox.op("serviceCallFailure")
    assert failure["callId"] == 6 and "negative" in failure["message"]
    call(7, 1, b"json")
    failure = await fox.op("serviceCallFailure")
    assert failure["callId"] == 7 and "encoding" in failure["message"]


async def test_an_empty_request_needs_no_bytes(hub):
    calls = []

    async def trigger(req: dict) -> dict:
        calls.append(req)
        return {"success": True, "message": "done"}

    Node(hub.bus, "/srv").service("/fg/trigger", "std_srvs/Trigger", trigger)
    fox = FoxClient(hub)
    services = await fox.until(
        lambda m: isinstance(m, dict) and m.get("op") == "advertiseServices"
        and any(s["name"] == "/fg/trigger" for s in m["services"]), "advertiseServices")
    sid = next(s["id"] for s in services["services"] if s["name"] == "/fg/trigger")
    for call_id, payload in enumerate([b"\x00\x01\x00\x00", b"\x00\x01\x00\x00\x00"]):
        fox.send(struct.pack("<BIII", 2, sid, call_id, 3) + b"cdr" + payload)
        resp = await fox.until(lambda m: isinstance(m, tuple) and m[0] == 3, "response")
        out = fox.codec.decode(resp[1][16:], hub.bus.types.srv("std_srvs/Trigger").response)
        assert out == {"success": True, "message": "done"}
    assert calls == [{}, {}]


async def test_calls_waiting_at_once_are_bounded(hub):
    node = Node(hub.bus, "/slow")
    gate = asyncio.get_running_loop().create_future()

    async def slow(req: dict) -> dict:
        await gate
        return {"sum": 0}

    node.service("/fg/slow", "rospy_tutorials/AddTwoInts", slow)
    fox = FoxClient(hub)
    services = await fox.until(
        lambda m: isinstance(m, dict) and m.get("op") == "advertiseServices"
        and any(s["name"] == "/fg/slow" for s in m["services"]), "advertiseServices")
    sid = next(s["id"] for s in services["services"] if s["name"] == "/fg/slow")
    payload = fox.codec.encode({"a": 1, "b": 2}, hub.bus.types.srv("rospy_tutorials/AddTwoInts")
                               .request)
    for call_id in range(MAX_CALLS + 1):
        fox.send(struct.pack("<BIII", 2, sid, call_id, 3) + b"cdr" + payload)
    failure = await fox.op("serviceCallFailure")
    assert failure["callId"] == MAX_CALLS and "already waiting" in failure["message"]
    gate.set_result(None)
    answered = set()
    while len(answered) < MAX_CALLS:
        frame = await fox.until(lambda m: isinstance(m, tuple) and m[0] == 3, "response")
        answered.add(struct.unpack_from("<I", frame[1], 5)[0])
    assert answered == set(range(MAX_CALLS))

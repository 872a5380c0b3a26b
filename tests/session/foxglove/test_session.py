"""The Foxglove session without sockets: frames into ``receive``, the outbox drained and decoded.

The bus, its bridge nodes and the codec are the real ones (tests/sansio.py's Hub); a frame is
handled by the time ``receive`` returns.
"""

from __future__ import annotations

import asyncio
import json
import struct

import orjson
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hitrobot_server.bus.cdr import codec_for
from hitrobot_server.nodes.base import Node
from hitrobot_server.protocol import foxglove as fg
from hitrobot_server.session.foxglove.services import MAX_CALLS
from hitrobot_server.session.foxglove.session import FoxgloveSession
from hitrobot_server.session.foxglove.shared import FoxgloveShared
from hitrobot_server.session.options import SessionOptions


class FoxClient:
    """One Foxglove client: text/binary frames in, the session's frames out (JSON as dicts,
    binary as ``(opcode, bytes)``)."""

    def __init__(self, hub, **options):
        self.bus = hub.bus
        self.shared = getattr(hub, "foxglove", None) or FoxgloveShared.for_bus(hub.bus)
        hub.foxglove = self.shared
        self.session = FoxgloveSession(hub.bus, SessionOptions(**options), self.shared)
        self.codec = codec_for(hub.bus.types)

    def send(self, obj: dict | str | bytes) -> None:
        if isinstance(obj, bytes):
            self.session.receive(obj, binary=True)
        else:
            self.session.receive(obj if isinstance(obj, str) else json.dumps(obj))

    async def frames(self, timeout: float = 5.0):
        frames = await asyncio.wait_for(self.session.outbox.get(), timeout)
        assert frames is not None, "the session closed its outbox"
        self.session.outbox.sent()
        return [orjson.loads(d) if not b else (d[0], d) for d, b in frames]

    async def until(self, pred, what: str, limit: int = 500):
        """The first output matching ``pred`` (binary time frames skipped past), bounded."""
        seen = []
        for _ in range(limit):
            for item in await self.frames():
                if pred(item):
                    return item
                seen.append(item)
        raise AssertionError(f"no {what} in {seen[-10:]}")

    async def op(self, name: str):
        return await self.until(lambda m: isinstance(m, dict) and m.get("op") == name, name)

    async def error(self):
        return await self.until(
            lambda m: isinstance(m, dict) and m.get("op") == "status" and m["level"] == fg.ERROR,
            "error status",
        )

    def channel(self, topic: str) -> dict:
        return self.shared.channel(self.bus.topic(topic))


async def test_server_info_then_a_channel_per_topic(hub):
    node = Node(hub.bus, "/pub")
    node.advertise("/fg/chatter", "std_msgs/String")
    fox = FoxClient(hub)
    info = (await fox.frames())[0]
    assert info["op"] == "serverInfo" and "clientPublish" in info["capabilities"]
    adv = await fox.op("advertise")
    topics = {c["topic"]: c for c in adv["channels"]}
    assert set(hub.bus.topics) == set(topics)
    assert topics["/fg/chatter"]["schemaName"] == "std_msgs/msg/String"
    assert topics["/fg/chatter"]["schema"] == "string data\n"
    node.advertise("/fg/later", "std_msgs/Int32")
    adv = await fox.op("advertise")
    assert [c["topic"] for c in adv["channels"]] == ["/fg/later"]
    node.close()
    gone = await fox.op("unadvertise")
    assert topics["/fg/chatter"]["id"] in gone["channelIds"]


async def test_topics_glob_hides_channels_and_refuses_publishing(make_hub):
    hub = await make_hub(topics_glob="/fg/*")
    Node(hub.bus, "/pub").advertise("/fg/ok", "std_msgs/String")
    Node(hub.bus, "/pub2").advertise("/secret", "std_msgs/String")
    fox = FoxClient(hub, topics_glob="/fg/*")
    adv = await fox.op("advertise")
    assert [c["topic"] for c in adv["channels"]] == ["/fg/ok"]
    fox.send({"op": "advertise", "channels": [{"id": 1, "topic": "/secret", "encoding": "cdr",
                                               "schemaName": "std_msgs/msg/String"}]})
    assert "--topics-glob" in (await fox.error())["message"]
    assert list(hub.bus.topic("/secret").publishers.values()) == ["/pub2"]


async def test_one_cdr_encoding_shared_by_every_subscriber(hub):
    node = Node(hub.bus, "/pub")
    node.advertise("/fg/chatter", "std_msgs/String")
    a, b = FoxClient(hub), FoxClient(hub)
    cid = a.channel("/fg/chatter")["id"]
    a.send({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": cid}]})
    b.send({"op": "subscribe", "subscriptions": [{"id": 2, "channelId": cid}]})
    message = node.publish("/fg/chatter", {"data": "hi"})
    got_a = await a.until(lambda m: isinstance(m, tuple) and m[0] == 1, "message data")
    got_b = await b.until(lambda m: isinstance(m, tuple) and m[0] == 1, "message data")
    cdr = message.cdr_bytes
    assert got_a[1][13:] is cdr or got_a[1][13:] == cdr
    assert struct.unpack_from("<I", got_a[1], 1)[0] == 1
    assert struct.unpack_from("<I", got_b[1], 1)[0] == 2
    assert a.codec.decode(got_b[1][13:], hub.bus.topic("/fg/chatter").mtype) == {"data": "hi"}
    encoded = []
    original = a.codec.encode
    a.codec.encode = lambda *args: encoded.append(1) or original(*args)
    try:
        node.publish("/fg/chatter", {"data": "again"})
    finally:
        del a.codec.encode
    assert encoded == [1]  # once for both clients


async def test_client_publish_reaches_the_bus_and_bad_cdr_is_refused(hub):
    got = []
    Node(hub.bus, "/sub").subscribe("/fg/cmd", "geometry_msgs/Twist", lambda m: got.append(m.msg))
    fox = FoxClient(hub)
    fox.send({"op": "advertise", "channels": [{"id": 7, "topic": "/fg/cmd", "encoding": "cdr",
                                               "schemaName": "geometry_msgs/msg/Twist"}]})
    twist = {"linear": {"x": 0.5, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 1.0}}
    cdr = fox.codec.encode(twist, hub.bus.types.msg("geometry_msgs/Twist"))
    fox.send(struct.pack("<BI", 1, 7) + cdr)
    assert got == [twist]
    fox.send(struct.pack("<BI", 1, 7) + cdr[:9])
    err = await fox.error()
    assert "does not match geometry_msgs/msg/Twist" in err["message"]
    assert len(got) == 1
    fox.send({"op": "advertise", "channels": [{"id": 8, "topic": "/fg/cmd", "encoding": "cdr",
                                               "schemaName": "std_msgs/msg/String"}]})
    assert "already has type" in (await fox.error())["message"]
    fox.send({"op": "advertise", "channels": [{"id": 9, "topic": "/fg/x", "encoding": "json",
                                               "schemaName": "std_msgs/msg/String"}]})
    assert "'encoding'" in (await fox.error())["message"]
    fox.send({"op": "unadvertise", "channelIds": [7]})
    assert fox.session.node not in hub.bus.topic("/fg/cmd").publishers.values()


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


async def test_parameters_get_set_and_updates(hub):
    fox = FoxClient(hub)
    fox.send({"op": "subscribeParameterUpdates", "parameterNames": ["/fg/gain"]})
    fox.send({"op": "setParameters", "id": "s", "parameters": [
        {"name": "/fg/gain", "value": 2, "type": "float64"},
        {"name": "/fg/blob", "value": "AQI=", "type": "byte_array"}]})
    update = await fox.op("parameterValues")
    assert update.get("id") is None and update["parameters"] == [
        {"name": "/fg/gain", "value": 2.0, "type": "float64"}]
    reply = await fox.op("parameterValues")
    assert reply["id"] == "s"
    assert hub.bus.params.get("/fg/blob") == [1, 2]  # JSON on the bus, as rosapi serves it
    fox.send({"op": "getParameters", "id": "g", "parameterNames": ["/fg/gain", "/fg/none"]})
    got = await fox.op("parameterValues")
    assert got == {"op": "parameterValues", "id": "g",
                   "parameters": [{"name": "/fg/gain", "value": 2.0, "type": "float64"}]}
    fox.send({"op": "setParameters", "parameters": [{"name": "/fg/gain", "value": 1},
                                                    {"name": "not a name!", "value": 3}]})
    assert "'name'" in (await fox.error())["message"]
    assert hub.bus.params.get("/fg/gain") == 2.0  # validated first: nothing was set


async def test_connection_graph_follows_the_bus(hub):
    fox = FoxClient(hub)
    fox.send({"op": "subscribeConnectionGraph"})
    first = await fox.op("connectionGraphUpdate")
    assert any(s["name"] == "/rosapi/topics" for s in first["advertisedServices"])
    node = Node(hub.bus, "/grapher")
    node.advertise("/fg/graph", "std_msgs/String")
    update = await fox.op("connectionGraphUpdate")
    assert {"name": "/fg/graph", "publisherIds": ["/grapher"]} in update["publishedTopics"]


async def test_time_comes_from_the_bus_clock(make_hub):
    hub = await make_hub()
    hub.bus.clock = lambda: 1234.5
    fox = FoxClient(hub)
    frame = await fox.until(lambda m: isinstance(m, tuple) and m[0] == 2, "time")
    assert struct.unpack_from("<Q", frame[1], 1)[0] == 1_234_500_000_000


async def test_authenticate_refuses_foxglove_clients(hub):
    fox = FoxClient(hub, authenticate=True, auth_secret="x" * 16)
    err = await fox.error()
    assert "--authenticate" in err["message"]
    assert await asyncio.wait_for(fox.session.outbox.get(), 1) is None  # closed, nothing else
    assert not any(fox.session.node in (n for n, _ in t.subscribers.values())
                   for t in hub.bus.topics.values())


async def test_close_releases_everything(hub):
    fox = FoxClient(hub)
    fox.send({"op": "advertise", "channels": [{"id": 1, "topic": "/fg/pub", "encoding": "cdr",
                                               "schemaName": "std_msgs/msg/String"}]})
    await fox.until(lambda m: isinstance(m, dict) and m.get("op") == "advertise"
                    and any(c["topic"] == "/fg/pub" for c in m["channels"]), "its channel")
    cid = fox.channel("/fg/pub")["id"]
    fox.send({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": cid}]})
    assert fox.session.subs == {1: "/fg/pub"}
    assert fox.session.node in hub.bus.nodes
    fox.session.close()
    assert fox.session.node not in hub.bus.nodes
    assert fox.session._changed not in hub.bus.watchers
    assert fox.session._changed not in hub.bus.remote_watchers
    for topic in hub.bus.topics.values():
        assert fox.session not in topic.publishers
        assert all(k[0] is not fox.session for k in topic.subscribers if isinstance(k, tuple))


# ---------------------------------------------------------------------- fuzz
_TEXT_OPS = st.one_of(
    st.builds(lambda op, f: {"op": op, **f}, st.sampled_from([*fg.CLIENT_OPS, "bogus"]),
              st.dictionaries(
                  st.sampled_from(["subscriptions", "subscriptionIds", "channels", "channelIds",
                                   "parameterNames", "parameters", "id"]),
                  st.one_of(st.integers(-3, 2**33), st.text(max_size=4), st.none(),
                            st.lists(st.integers(-1, 5), max_size=3),
                            st.lists(st.dictionaries(st.sampled_from(
                                ["id", "channelId", "topic", "encoding", "schemaName", "name",
                                 "value", "type"]), st.integers(-1, 3) | st.text(max_size=3),
                                max_size=4), max_size=2)),
                  min_size=1, max_size=3)),
)
_BINARY = st.one_of(
    st.binary(max_size=40),
    st.builds(lambda op, a, b, n, rest: struct.pack("<BIII", op, a, b, n) + rest,
              st.sampled_from([1, 2, 3, 255]), st.integers(0, 2**32 - 1),
              st.integers(0, 2**32 - 1), st.integers(0, 2**32 - 1), st.binary(max_size=20)),
)


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(frames=st.lists(st.one_of(_TEXT_OPS.map(json.dumps), _BINARY, st.text(max_size=12)),
                       min_size=1, max_size=30))
async def test_fuzzed_frames_never_break_the_session_or_a_witness(hub, frames):
    """Junk of every shape: at worst error statuses to its sender; the sender still answers and
    another client on the same bus keeps getting its messages."""
    node = getattr(hub, "fuzz_node", None) or Node(hub.bus, "/fuzz")
    hub.fuzz_node = node
    node.advertise("/fg/witness", "std_msgs/String")
    witness, fuzzer = FoxClient(hub), FoxClient(hub)
    cid = witness.channel("/fg/witness")["id"]
    witness.send({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": cid}]})
    for frame in frames:
        fuzzer.send(frame)
    fuzzer.send({"op": "getParameters", "parameterNames": ["/nope"], "id": "sentinel"})
    await fuzzer.until(lambda m: isinstance(m, dict) and m.get("id") == "sentinel", "sentinel")
    node.publish("/fg/witness", {"data": "still here"})
    data = await witness.until(lambda m: isinstance(m, tuple) and m[0] == 1, "witness data")
    assert witness.codec.decode(data[1][13:], hub.bus.topic("/fg/witness").mtype) == {
        "data": "still here"}
    fuzzer.session.close()
    witness.session.close()


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


async def test_forgotten_channels_of_topics_gone_keep_the_table_bounded(hub, monkeypatch):
    monkeypatch.setattr("hitrobot_server.session.foxglove.shared.MAX_REMEMBERED", 3)
    node = Node(hub.bus, "/churn")
    fox = FoxClient(hub)
    for i in range(6):
        node.advertise(f"/fg/churn{i}", "std_msgs/String")
        fox.shared.channel(hub.bus.topic(f"/fg/churn{i}"))
        hub.bus.unadvertise(f"/fg/churn{i}", node)
        hub.bus._expire(hub.bus.topic(f"/fg/churn{i}"))
    fox.shared.prune()
    names = {name for name, _type in fox.shared._channels}
    assert names and names <= set(hub.bus.topics)
    assert not any(name.startswith("/fg/churn") for name in names)


async def test_subscribing_a_channel_whose_topic_just_went_is_an_error(make_hub):
    hub = await make_hub()
    hub.bus.unregister_timeout = 0  # an unused topic goes at once
    node = Node(hub.bus, "/brief")
    node.advertise("/fg/brief", "std_msgs/String")
    fox = FoxClient(hub)
    cid = fox.channel("/fg/brief")["id"]
    assert cid in fox.session.channels
    node.close()  # gone from the bus; the client hears of it only after this step
    fox.send({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": cid}]})
    got: dict[str, dict] = {}

    def note(m) -> bool:  # the announcement is a control frame: it may overtake the status
        if isinstance(m, dict) and m.get("op") == "status" and m["level"] == fg.ERROR:
            got["error"] = m
        elif isinstance(m, dict) and m.get("op") == "unadvertise":
            got["gone"] = m
        return len(got) == 2

    await fox.until(note, "an error status and an unadvertise")
    assert "does not exist" in got["error"]["message"]
    assert fox.session.subs == {}
    assert cid in got["gone"]["channelIds"]


async def test_params_glob_limits_foxglove_parameters(make_hub):
    hub = await make_hub()
    hub.bus.params.set("/open/gain", 1)
    hub.bus.params.set("/secret/key", "x")
    fox = FoxClient(hub, params_glob="/open/*")
    fox.send({"op": "getParameters", "id": "all", "parameterNames": []})
    got = await fox.op("parameterValues")
    assert got["parameters"] == [{"name": "/open/gain", "value": 1}]
    fox.send({"op": "getParameters", "id": "one", "parameterNames": ["/secret/key"]})
    assert (await fox.op("parameterValues"))["parameters"] == []
    fox.send({"op": "setParameters", "parameters": [{"name": "/open/gain", "value": 2},
                                                    {"name": "/secret/key", "value": "y"}]})
    assert "--params-glob" in (await fox.error())["message"]
    assert hub.bus.params.get("/open/gain") == 1 and hub.bus.params.get("/secret/key") == "x"
    fox.send({"op": "subscribeParameterUpdates", "parameterNames": ["/secret/key", "/open/gain"]})
    hub.bus.params.set("/secret/key", "z")
    hub.bus.params.set("/open/gain", 3)
    update = await fox.op("parameterValues")
    assert update["parameters"] == [{"name": "/open/gain", "value": 3}]


async def test_a_message_that_cannot_be_cdr_is_skipped_with_one_warning(hub):
    node = Node(hub.bus, "/odd")
    node.advertise("/fg/odd", "std_msgs/Int32")
    fox = FoxClient(hub)
    cid = fox.channel("/fg/odd")["id"]
    fox.send({"op": "subscribe", "subscriptions": [{"id": 4, "channelId": cid}]})
    node.publish("/fg/odd", {"data": "not a number"})
    node.publish("/fg/odd", {"data": "nor this"})
    node.publish("/fg/odd", {"data": 7})
    seen = []
    data = await fox.until(lambda m: seen.append(m) or (isinstance(m, tuple) and m[0] == 1),
                           "message data")
    warnings = [m for m in seen if isinstance(m, dict) and m.get("op") == "status"]
    assert len(warnings) == 1 and warnings[0]["level"] == fg.WARNING
    assert "/fg/odd" in warnings[0]["message"]
    assert fox.codec.decode(data[1][13:], hub.bus.types.msg("std_msgs/Int32")) == {"data": 7}


async def test_set_parameters_is_all_or_nothing_and_names_the_limit(hub):
    """Issue 37: an op refused at its 7th name (past the store's 16 MB) sets none of them,
    and says why without an 'internal error' (nor a traceback in the log)."""
    fox = FoxClient(hub)
    value = "v" * 990_000
    fill = [{"name": f"/fill/p{i}", "value": value} for i in range(10)]
    fox.send({"op": "setParameters", "id": "fill", "parameters": fill})
    await fox.until(lambda m: isinstance(m, dict) and m.get("id") == "fill", "the fill set")
    names = [f"/op/p{i}" for i in range(7)]
    fox.send({"op": "setParameters", "id": "op",
              "parameters": [{"name": n, "value": value} for n in names]})
    err = await fox.error()
    assert "16000000" in err["message"] and "no parameter was set" in err["message"]
    assert "internal error" not in err["message"]
    assert not any(hub.bus.params.has(n) for n in names)
    assert hub.bus.params.has("/fill/p9")

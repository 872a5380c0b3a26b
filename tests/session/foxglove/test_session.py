"""The session itself: the time tick from the bus clock, ``--authenticate`` refusing Foxglove
clients, close releasing everything, fuzzed frames never breaking it (``session.py``)."""

from __future__ import annotations

import asyncio
import json
import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hitrobot_server.nodes.base import Node
from hitrobot_server.protocol import foxglove as fg
from tests.session.foxglove.client import FoxClient


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


@pytest.mark.fuzz
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

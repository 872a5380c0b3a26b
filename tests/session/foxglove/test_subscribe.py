"""Subscriptions: messages framed for each subscriber from one CDR encoding, a channel whose
topic has gone, a message that cannot be CDR (``subscribe.py``)."""

from __future__ import annotations

import struct

from hitrobot_server.nodes.base import Node
from hitrobot_server.protocol import foxglove as fg
from tests.session.foxglove.client import FoxClient


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

"""Publish/subscribe semantics, sessions driven sans-I/O (no socket): see tests/sansio.py."""

from __future__ import annotations

import base64
import time


async def test_pubsub_echoes_topic_spelling_and_fills_defaults(hub):
    a = hub.open()
    b = hub.open()
    await b.send({"op": "subscribe", "id": "s1", "topic": "chatter", "type": "std_msgs/String"})
    await b.send({"op": "subscribe", "id": "s2", "topic": "/chatter", "type": "std_msgs/String"})
    await a.send({"op": "publish", "topic": "/chatter", "msg": {}})
    first = await b.expect(op="publish")
    second = await b.expect(op="publish")
    assert {first["topic"], second["topic"]} == {"chatter", "/chatter"}
    assert first["msg"] == {"data": ""}
    assert set(first) == {"op", "topic", "msg"}


async def test_header_stamp_filled_and_uint8_base64_and_nan_null(peer):
    await peer.send({"op": "subscribe", "topic": "/img", "type": "sensor_msgs/CompressedImage"})
    await peer.send({"op": "subscribe", "topic": "/f", "type": "std_msgs/Float64"})
    before = time.time()
    await peer.send({"op": "publish", "topic": "/img",
                       "msg": {"header": {"frame_id": "cam"}, "format": "png",
                               "data": [1, 2, 255]}})
    got = await peer.expect(op="publish", topic="/img")
    assert got["msg"]["header"]["frame_id"] == "cam"
    assert abs(got["msg"]["header"]["stamp"]["secs"] - before) < 5
    assert base64.b64decode(got["msg"]["data"]) == bytes([1, 2, 255])
    await peer.send({"op": "publish", "topic": "/f", "msg": {"data": None}})
    got = await peer.expect(op="publish", topic="/f")
    assert got["msg"]["data"] is None


async def test_latched_topic_replays_to_each_new_subscriber(hub):
    pub = hub.open()
    await pub.send({"op": "advertise", "topic": "/latched", "type": "std_msgs/String",
                    "latch": True})
    await pub.send({"op": "publish", "topic": "/latched", "msg": {"data": "kept"}})
    for _ in range(2):
        late = hub.open()
        await late.send({"op": "subscribe", "topic": "/latched"})
        got = await late.expect(op="publish", topic="/latched")
        assert got["msg"]["data"] == "kept"
        await late.close()


async def test_unsubscribe_by_id_keeps_other_subscription(peer):
    await peer.send({"op": "subscribe", "id": "one", "topic": "/u", "type": "std_msgs/Int32"})
    await peer.send({"op": "subscribe", "id": "two", "topic": "/u", "type": "std_msgs/Int32"})
    await peer.send({"op": "unsubscribe", "id": "one", "topic": "/u"})
    await peer.send({"op": "publish", "topic": "/u", "msg": {"data": 1}})
    assert (await peer.expect(op="publish"))["msg"]["data"] == 1
    await peer.send({"op": "unsubscribe", "topic": "/u"})
    await peer.send({"op": "publish", "topic": "/u", "msg": {"data": 2}})
    await peer.expect_none(op="publish", timeout=0.3)


async def test_throttled_burst_delivers_its_last_message(hub):
    pub = hub.open()
    sub = hub.open()
    await sub.send({"op": "subscribe", "topic": "/burst", "type": "std_msgs/Int32",
                    "throttle_rate": 200})
    for i in range(10):
        await pub.send({"op": "publish", "topic": "/burst", "msg": {"data": i}})
    first = await sub.expect(op="publish")
    last = await sub.expect(op="publish", timeout=2)
    assert first["msg"]["data"] == 0
    assert last["msg"]["data"] == 9
    await sub.expect_none(op="publish", timeout=0.4)


async def test_queue_length_keeps_newest_under_throttle(hub):
    pub = hub.open()
    sub = hub.open()
    await sub.send({"op": "subscribe", "id": "a", "topic": "/q", "type": "std_msgs/Int32",
                    "throttle_rate": 100, "queue_length": 3})
    await sub.send({"op": "subscribe", "id": "b", "topic": "/q", "type": "std_msgs/Int32",
                    "throttle_rate": 500, "queue_length": 1})
    for i in range(10):
        await pub.send({"op": "publish", "topic": "/q", "msg": {"data": i}})
    got = [(await sub.expect(op="publish", timeout=2))["msg"]["data"] for _ in range(4)]
    # effective: lowest throttle (100 ms), highest queue_length (3): first, then newest three
    assert got == [0, 7, 8, 9]

"""Publish/subscribe semantics over real WebSockets."""

from __future__ import annotations

import asyncio
import base64
import time

from ..helpers import WsClient


async def test_pubsub_echoes_topic_spelling_and_fills_defaults(server):
    a = await WsClient.open(server.port)
    b = await WsClient.open(server.port)
    await b.send({"op": "subscribe", "id": "s1", "topic": "chatter", "type": "std_msgs/String"})
    await b.send({"op": "subscribe", "id": "s2", "topic": "/chatter", "type": "std_msgs/String"})
    await asyncio.sleep(0.05)
    await a.send({"op": "publish", "topic": "/chatter", "msg": {}})
    first = await b.expect(op="publish")
    second = await b.expect(op="publish")
    assert {first["topic"], second["topic"]} == {"chatter", "/chatter"}
    assert first["msg"] == {"data": ""}
    assert set(first) == {"op", "topic", "msg"}


async def test_header_stamp_filled_and_uint8_base64_and_nan_null(client):
    await client.send({"op": "subscribe", "topic": "/img", "type": "sensor_msgs/CompressedImage"})
    await client.send({"op": "subscribe", "topic": "/f", "type": "std_msgs/Float64"})
    await asyncio.sleep(0.05)
    before = time.time()
    await client.send({"op": "publish", "topic": "/img",
                       "msg": {"header": {"frame_id": "cam"}, "format": "png",
                               "data": [1, 2, 255]}})
    got = await client.expect(op="publish", topic="/img")
    assert got["msg"]["header"]["frame_id"] == "cam"
    assert abs(got["msg"]["header"]["stamp"]["secs"] - before) < 5
    assert base64.b64decode(got["msg"]["data"]) == bytes([1, 2, 255])
    await client.send({"op": "publish", "topic": "/f", "msg": {"data": None}})
    got = await client.expect(op="publish", topic="/f")
    assert got["msg"]["data"] is None


async def test_latched_topic_replays_to_each_new_subscriber(server):
    pub = await WsClient.open(server.port)
    await pub.send({"op": "advertise", "topic": "/latched", "type": "std_msgs/String",
                    "latch": True})
    await pub.send({"op": "publish", "topic": "/latched", "msg": {"data": "kept"}})
    await asyncio.sleep(0.05)
    for _ in range(2):
        late = await WsClient.open(server.port)
        await late.send({"op": "subscribe", "topic": "/latched"})
        got = await late.expect(op="publish", topic="/latched")
        assert got["msg"]["data"] == "kept"
        await late.close()


async def test_unsubscribe_by_id_keeps_other_subscription(client):
    await client.send({"op": "subscribe", "id": "one", "topic": "/u", "type": "std_msgs/Int32"})
    await client.send({"op": "subscribe", "id": "two", "topic": "/u", "type": "std_msgs/Int32"})
    await client.send({"op": "unsubscribe", "id": "one", "topic": "/u"})
    await client.send({"op": "publish", "topic": "/u", "msg": {"data": 1}})
    assert (await client.expect(op="publish"))["msg"]["data"] == 1
    await client.send({"op": "unsubscribe", "topic": "/u"})
    await client.send({"op": "publish", "topic": "/u", "msg": {"data": 2}})
    await client.expect_none(op="publish", timeout=0.3)


async def test_throttled_burst_delivers_its_last_message(server):
    pub = await WsClient.open(server.port)
    sub = await WsClient.open(server.port)
    await sub.send({"op": "subscribe", "topic": "/burst", "type": "std_msgs/Int32",
                    "throttle_rate": 200})
    await asyncio.sleep(0.05)
    for i in range(10):
        await pub.send({"op": "publish", "topic": "/burst", "msg": {"data": i}})
    first = await sub.expect(op="publish")
    last = await sub.expect(op="publish", timeout=2)
    assert first["msg"]["data"] == 0
    assert last["msg"]["data"] == 9
    await sub.expect_none(op="publish", timeout=0.4)


async def test_queue_length_keeps_newest_under_throttle(server):
    pub = await WsClient.open(server.port)
    sub = await WsClient.open(server.port)
    await sub.send({"op": "subscribe", "id": "a", "topic": "/q", "type": "std_msgs/Int32",
                    "throttle_rate": 100, "queue_length": 3})
    await sub.send({"op": "subscribe", "id": "b", "topic": "/q", "type": "std_msgs/Int32",
                    "throttle_rate": 500, "queue_length": 1})
    await asyncio.sleep(0.05)
    for i in range(10):
        await pub.send({"op": "publish", "topic": "/q", "msg": {"data": i}})
    got = [(await sub.expect(op="publish", timeout=2))["msg"]["data"] for _ in range(4)]
    # effective: lowest throttle (100 ms), highest queue_length (3): first, then newest three
    assert got == [0, 7, 8, 9]

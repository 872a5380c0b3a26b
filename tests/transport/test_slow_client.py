"""A client that stops reading must not delay the bus or other clients."""

from __future__ import annotations

import asyncio

from websockets.asyncio.client import connect

from tests.helpers import WsClient, round_trip


async def test_stalled_client_does_not_delay_fast_one(make_server):
    server = await make_server(send_buffer_limit=200_000)
    # the slow client subscribes, then never reads; tiny socket buffers make it back up fast
    slow = await connect(f"ws://127.0.0.1:{server.port}", max_size=None, max_queue=1)
    await slow.send('{"op":"subscribe","topic":"/firehose","type":"std_msgs/String"}')
    await slow.send('{"op":"call_service","id":"subscribed","service":"/rosapi/get_time"}')
    while '"subscribed"' not in await asyncio.wait_for(slow.recv(), 5):  # round trip
        pass
    slow.transport.pause_reading()
    fast = await WsClient.open(server.port)
    pub = await WsClient.open(server.port)
    await fast.send({"op": "subscribe", "topic": "/firehose", "type": "std_msgs/String"})
    await round_trip(fast)
    payload = "x" * 20_000
    n = 600  # ~12 MB in all: far beyond the slow client's buffers

    async def publish() -> None:
        for i in range(n):
            await pub.send({"op": "publish", "topic": "/firehose",
                            "msg": {"data": f"{i}:{payload}"}})
            await asyncio.sleep(0.003)  # a paced stream a reading client keeps up with

    publisher = asyncio.create_task(publish())
    got = []
    while len(got) < n:  # the reading client gets every message, in order
        msg = await fast.expect(op="publish", timeout=10)
        got.append(int(msg["msg"]["data"].split(":")[0]))
    await publisher
    assert got == list(range(n))
    slow_session = max(server.sessions, key=lambda s: s.outbox.dropped)
    assert slow_session.outbox.dropped > 0  # the slow one lost its own oldest messages
    assert slow_session.outbox.buffered <= 200_000 + 30_000
    slow.transport.resume_reading()
    await slow.close()

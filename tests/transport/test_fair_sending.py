"""A slow link thins the big stream, never the small topic (issue 22), over real sockets."""

from __future__ import annotations

import asyncio
import json
import socket
import time

from websockets.asyncio.client import connect

from hitrobot_server.nodes.diagnostics import WARN, DiagnosticsNode
from tests.helpers import WsClient, round_trip

BIG = "/fair/cloud"
SMALL = "/fair/pose"
RATE = 400_000  # bytes/s the slow reader takes: a weak link, scaled down
BIG_BYTES = 60_000  # at 20 Hz: 1.2 MB/s, three times what the link carries
SMALL_COUNT = 60  # at 50 Hz
AGE_BOUND = 1.0  # s; a single FIFO makes it several seconds (the issue measured 3.7 s median)


async def paced_reader(port: int) -> tuple:
    """A WebSocket client with a small receive buffer that reads at most RATE bytes/s."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 32 * 1024)
    sock.connect(("127.0.0.1", port))
    sock.setblocking(False)
    return await connect(f"ws://127.0.0.1:{port}", sock=sock, max_size=None, max_queue=1)


async def test_a_slow_reader_gets_every_small_message_fresh_and_in_order(make_server):
    server = await make_server(send_buffer_limit=300_000)
    slow = await paced_reader(server.port)
    fast = await WsClient.open(server.port)
    pub = await WsClient.open(server.port)
    for topic in (BIG, SMALL):
        await pub.send({"op": "advertise", "topic": topic, "type": "std_msgs/String"})
    await slow.send(json.dumps({"op": "subscribe", "topic": BIG, "type": "std_msgs/String",
                                "fragment_size": 16_000}))
    await slow.send(json.dumps({"op": "subscribe", "topic": SMALL, "type": "std_msgs/String"}))
    await fast.send({"op": "subscribe", "topic": BIG, "type": "std_msgs/String"})
    await fast.send({"op": "subscribe", "topic": SMALL, "type": "std_msgs/String"})
    await slow.send(json.dumps({"op": "call_service", "id": "ready",
                                "service": "/rosapi/get_time"}))
    while '"ready"' not in await asyncio.wait_for(slow.recv(), 5):
        pass
    await round_trip(fast)

    small_seen: list[tuple[int, float]] = []  # (index, age on arrival)
    big_seen = 0
    fragments = 0
    stop = asyncio.Event()
    all_small = asyncio.Event()

    async def read_slowly() -> None:
        nonlocal big_seen, fragments
        while not stop.is_set():
            try:
                frame = await asyncio.wait_for(slow.recv(), 0.5)
            except TimeoutError:
                continue
            msg = json.loads(frame)
            if msg.get("op") == "fragment":
                fragments += 1
                big_seen += msg["num"] == msg["total"] - 1
            elif msg.get("topic") == SMALL:
                index, stamp = msg["msg"]["data"].split(":")
                small_seen.append((int(index), time.monotonic() - float(stamp)))
                if len(small_seen) == SMALL_COUNT:
                    all_small.set()
            await asyncio.sleep(len(frame) / RATE)  # the link's pace

    async def read_fast() -> tuple[list[int], int]:
        small, big = [], 0
        while len(small) < SMALL_COUNT or big < 24:
            msg = await fast.expect(op="publish", timeout=10)
            if msg["topic"] == SMALL:
                small.append(int(msg["msg"]["data"].split(":")[0]))
            else:
                big += 1
        return small, big

    reader = asyncio.create_task(read_slowly())
    fast_reader = asyncio.create_task(read_fast())
    big = "x" * BIG_BYTES
    for i in range(SMALL_COUNT):  # 50 Hz small, on 2 of every 5 ticks a big one (20 Hz)
        await pub.send({"op": "publish", "topic": SMALL,
                        "msg": {"data": f"{i}:{time.monotonic()}"}})
        if i % 5 in (0, 2):
            await pub.send({"op": "publish", "topic": BIG, "msg": {"data": f"{i}:{big}"}})
        await asyncio.sleep(0.02)  # the publisher's rate, not a synchronisation

    fast_small, fast_big = await fast_reader
    assert fast_small == list(range(SMALL_COUNT)) and fast_big == 24  # a fast reader: all

    await asyncio.wait_for(all_small.wait(), 20)
    stop.set()
    await reader
    assert [i for i, _ in small_seen] == list(range(SMALL_COUNT))  # all, in order
    ages = sorted(age for _, age in small_seen)
    assert ages[int(len(ages) * 0.95)] <= AGE_BOUND, ages[-10:]
    slow_session = next(s for s in server.sessions if s.outbox.drops(BIG))
    assert slow_session.outbox.drops(SMALL) == 0  # only the big one was thinned
    assert 0 < big_seen < 24 and fragments > big_seen
    sub = slow_session.subscriptions.subs[BIG]
    assert sub.dropped == slow_session.outbox.drops(BIG)
    nodes = [*server.site.nodes, *(n for robot in server.robots for n in robot.nodes)]
    diagnostics = next(n for n in nodes if isinstance(n, DiagnosticsNode))
    item = diagnostics.slow_links()  # what /diagnostics_agg publishes: per client and topic
    assert item["level"] == WARN
    assert item["values"] == [{"key": f"{slow_session.node} {BIG}", "value": str(sub.dropped)}]
    await slow.close()
    await asyncio.gather(fast.close(), pub.close())


async def test_replies_are_never_dropped_under_overload(make_server):
    server = await make_server(send_buffer_limit=100_000)
    slow = await paced_reader(server.port)
    pub = await WsClient.open(server.port)
    await pub.send({"op": "advertise", "topic": BIG, "type": "std_msgs/String"})
    await slow.send(json.dumps({"op": "subscribe", "topic": BIG, "type": "std_msgs/String"}))
    await slow.send(json.dumps({"op": "call_service", "id": "ready",
                                "service": "/rosapi/get_time"}))
    while '"ready"' not in await asyncio.wait_for(slow.recv(), 5):
        pass
    slow.transport.pause_reading()
    big = "y" * 50_000
    for i in range(100):  # 5 MB of topic data against a 100 kB buffer, and 50 calls among it
        await pub.send({"op": "publish", "topic": BIG, "msg": {"data": f"{i}:{big}"}})
        if i % 2 == 0:
            await slow.send(json.dumps({"op": "call_service", "id": f"c{i}",
                                        "service": "/rosapi/get_time"}))
    await round_trip(pub)
    slow.transport.resume_reading()
    replies: list[str] = []
    deadline = time.monotonic() + 20
    while len(replies) < 50 and time.monotonic() < deadline:
        msg = json.loads(await asyncio.wait_for(slow.recv(), 10))
        if msg.get("op") == "service_response":
            assert msg["result"] is True
            replies.append(msg["id"])
    assert replies == [f"c{i}" for i in range(0, 100, 2)]
    session = next(s for s in server.sessions if s.outbox.drops(BIG))
    assert session.outbox.drops(BIG) > 0
    await asyncio.gather(slow.close(), pub.close())

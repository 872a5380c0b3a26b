"""With the send window (the default; --no-send-window turns it off), a WebSocket client that
shows a standing queue is held: what it has not read stays under its window, its pongs let more
through, and a pose waits behind the window, not behind megabytes. A client that reads what it
is sent, or answers no ping at all, is never held.

The client is websockets' own sans-I/O ``ClientProtocol`` over a real socket, so the test
decides when its pongs go out (an ordinary client sends them as soon as it reads a ping).
"""

from __future__ import annotations

import asyncio
import json

from websockets.client import ClientProtocol
from websockets.frames import Frame, Opcode
from websockets.uri import parse_uri

from hitrobot_server.transport.flight import ARM_AGE, ARM_SPAN, INITIAL_WINDOW, WATCH_EVERY
from hitrobot_server.transport.websocket import COUNT_EVERY, window_tick
from tests.helpers import WsClient, round_trip, until

BIG, POSE = "/window/cloud", "/window/pose"


class PongWithholdingClient:
    """A WebSocket client whose pongs are sent only when the test says so."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter):
        self.reader, self.writer = reader, writer
        self.protocol = ClientProtocol(parse_uri("ws://127.0.0.1/"), max_size=None)
        self.pings: list[bytes] = []
        self.texts: list[str] = []
        self.received = 0  # payload bytes of data frames read so far
        self.withhold = False

    @classmethod
    async def open(cls, port: int) -> PongWithholdingClient:
        client = cls(*await asyncio.open_connection("127.0.0.1", port))
        client.protocol.send_request(client.protocol.connect())
        await client.flush()
        while client.protocol.handshake_exc is None and not client._handshaken():
            await client.read_some(5.0)
        assert client.protocol.handshake_exc is None
        return client

    def _handshaken(self) -> bool:
        return self.protocol.state.name == "OPEN"

    async def flush(self) -> None:
        data = b"".join(self.protocol.data_to_send())
        if self.withhold:  # the automatic pongs are what this client holds back
            return
        self.writer.write(data)
        await self.writer.drain()

    async def send(self, obj: dict) -> None:
        self.protocol.send_text(json.dumps(obj).encode())
        pongs_held, self.withhold = self.withhold, False
        if pongs_held:  # drop the queued pongs, keep the text
            self.protocol.data_to_send()
            self.protocol.send_text(json.dumps(obj).encode())
        await self.flush()
        self.withhold = pongs_held

    async def read_some(self, timeout: float) -> bool:
        """Read what arrives within ``timeout``; False when nothing did."""
        try:
            data = await asyncio.wait_for(self.reader.read(1 << 16), timeout)
        except TimeoutError:
            return False
        if not data:
            return False
        self.protocol.receive_data(data)
        for event in self.protocol.events_received():
            if isinstance(event, Frame) and event.opcode is Opcode.PING:
                self.pings.append(bytes(event.data))
            elif isinstance(event, Frame) and event.opcode in (Opcode.TEXT, Opcode.CONT):
                self.received += len(event.data)
                self.texts.append(bytes(event.data).decode(errors="replace"))
        await self.flush()
        return True

    def close(self) -> None:
        self.writer.transport.abort()

    async def pong_all(self) -> None:
        """Answer the last ping seen (which answers every earlier one too)."""
        self.withhold = False
        self.protocol.data_to_send()  # automatic pongs held back so far: replaced by this one
        self.protocol.send_pong(self.pings[-1])
        await self.flush()

    async def read_until(self, needle: str, max_bytes: int, timeout: float = 10.0) -> int:
        """Read until a text frame holds ``needle``; returns the data bytes read before it."""
        start = self.received
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        seen = len(self.texts)
        while loop.time() < deadline and self.received - start <= max_bytes:
            for text in self.texts[seen:]:
                if needle in text:
                    return self.received - start
            seen = len(self.texts)
            await self.read_some(deadline - loop.time())
        raise AssertionError(f"{needle!r} not within {max_bytes} bytes ({self.received - start})")


async def test_a_client_with_a_standing_queue_is_held_and_a_pong_lets_the_pose_through(
        make_server):
    server = await make_server()
    client = await PongWithholdingClient.open(server.port)
    pub = await WsClient.open(server.port)
    for topic in (BIG, POSE):
        await pub.send({"op": "advertise", "topic": topic, "type": "std_msgs/String"})
    await client.send({"op": "subscribe", "topic": BIG, "type": "std_msgs/String",
                       "fragment_size": 16_000})
    await client.send({"op": "subscribe", "topic": POSE, "type": "std_msgs/String"})
    await client.send({"op": "call_service", "id": "ready", "service": "/rosapi/get_time"})
    await client.read_until('"ready"', max_bytes=1 << 20)
    loop = asyncio.get_running_loop()
    deadline = loop.time() + 10.0
    while not client.pings and loop.time() < deadline:  # its first ping, answered at once
        await client.read_some(deadline - loop.time())
    assert client.pings, "the server watches each client with pings"
    await round_trip(pub)

    # From here on the client reads but answers no ping: what it read is unconfirmed, as with
    # a client whose link holds a queue. Once a ping waited ARM_AGE + ARM_SPAN for its pong the
    # next bytes sent to it find it held.
    client.withhold = True
    seen = len(client.pings)
    deadline = loop.time() + 10.0
    while len(client.pings) == seen and loop.time() < deadline:  # pings go ten times a second
        await pub.send({"op": "publish", "topic": BIG, "msg": {"data": "w" * 20_000}})
        await client.read_some(0.05)
    assert len(client.pings) > seen, "a ping follows the bytes sent"
    pinged_at = loop.time()
    while loop.time() < pinged_at + ARM_AGE + ARM_SPAN + 0.1:  # its pong is now that late
        await client.read_some(pinged_at + ARM_AGE + ARM_SPAN + 0.1 - loop.time())

    body = "c" * 200_000
    for _ in range(15):  # 3 MB of cloud, far more than a window
        await pub.send({"op": "publish", "topic": BIG, "msg": {"data": body}})
    await round_trip(pub)
    before = client.received
    most = COUNT_EVERY + INITIAL_WINDOW + 64 * 1024  # counted late, then a window at most
    while await client.read_some(0.5):  # all the server lets out without a pong
        assert client.received - before <= most
    held = client.received - before
    assert 0 < held <= most, held  # a reader this fast had taken all 3 MB

    await pub.send({"op": "publish", "topic": POSE, "msg": {"data": "pose-1"}})
    await round_trip(pub)
    assert not await client.read_some(0.3)  # the window is full: the pose waits in the outbox
    await client.pong_all()
    # the pose is among the next picks from the outbox: behind a few 16 kB fragments at most,
    # not behind the megabytes still queued for the cloud
    assert await client.read_until("pose-1", max_bytes=256 * 1024) <= 96 * 1024
    client.close()


async def test_a_client_that_reads_what_it_is_sent_is_not_held(make_server):
    """A fast reader gets a flood at the pace it reads it, pinged ten times a second."""
    server = await make_server()
    client = await WsClient.open(server.port)
    pub = await WsClient.open(server.port)
    await pub.send({"op": "advertise", "topic": BIG, "type": "std_msgs/String"})
    await client.send({"op": "subscribe", "topic": BIG, "type": "std_msgs/String"})
    await round_trip(client)
    for i in range(40):  # 8 MB
        await pub.send({"op": "publish", "topic": BIG,
                        "msg": {"data": f"{i:03d}" + "c" * 200_000}})
    await round_trip(pub)
    got = [await client.expect(op="publish", timeout=10.0) for _ in range(40)]
    assert [m["msg"]["data"][:3] for m in got] == [f"{i:03d}" for i in range(40)]  # none dropped
    await client.close()


async def test_without_send_window_the_server_sends_no_pings(make_server):
    """Without the window (the default; --no-send-window) a client is never pinged (nor held
    back by pongs)."""
    server = await make_server(send_window=False)
    client = await PongWithholdingClient.open(server.port)
    pub = await WsClient.open(server.port)
    await pub.send({"op": "advertise", "topic": BIG, "type": "std_msgs/String"})
    await client.send({"op": "subscribe", "topic": BIG, "type": "std_msgs/String"})
    await client.send({"op": "call_service", "id": "ready", "service": "/rosapi/get_time"})
    await client.read_until('"ready"', max_bytes=1 << 20)
    client.withhold = True
    for _ in range(5):  # 1 MB, more than a window would let out unanswered
        await pub.send({"op": "publish", "topic": BIG, "msg": {"data": "c" * 200_000}})
    await round_trip(pub)
    before = client.received
    while client.received - before < 800_000 and await client.read_some(2.0):
        pass
    assert client.received - before >= 800_000 and not client.pings
    client.close()


async def test_a_client_that_never_pongs_is_never_held(make_server):
    """A client library that answers no ping gives the window nothing to go by: it is served
    as without a window (the fair outbox and the kernel's queue), from its first byte."""
    server = await make_server()
    client = await PongWithholdingClient.open(server.port)
    client.withhold = True  # from the start: no pong ever
    pub = await WsClient.open(server.port)
    await pub.send({"op": "advertise", "topic": BIG, "type": "std_msgs/String"})
    await client.send({"op": "subscribe", "topic": BIG, "type": "std_msgs/String"})
    await client.send({"op": "call_service", "id": "ready", "service": "/rosapi/get_time"})
    await client.read_until('"ready"', max_bytes=1 << 20)
    for _ in range(10):  # 2 MB, far more than a window
        await pub.send({"op": "publish", "topic": BIG, "msg": {"data": "c" * 200_000}})
    await round_trip(pub)
    before = client.received
    while client.received - before < 1_800_000 and await client.read_some(0.5):
        pass
    assert client.received - before >= 1_800_000 and client.pings
    client.close()


async def test_an_idle_client_wakes_nothing_and_is_not_pinged(make_server):
    """A client subscribed to a quiet topic (or to nothing) is not pinged while nothing is
    sent to it, and the windows' tick stops: idle clients cost the server no wake-ups. A
    message sent wakes the tick, and a ping follows it."""
    server = await make_server()
    tick = window_tick()
    client = await PongWithholdingClient.open(server.port)
    pub = await WsClient.open(server.port)
    await pub.send({"op": "advertise", "topic": POSE, "type": "std_msgs/String"})
    await client.send({"op": "subscribe", "topic": POSE, "type": "std_msgs/String"})
    await client.send({"op": "call_service", "id": "ready", "service": "/rosapi/get_time"})
    await client.read_until('"ready"', max_bytes=1 << 20)
    await round_trip(pub)
    await until(lambda: not tick.running, "the tick stopping once nothing flows", 5)
    for _ in range(20):  # what was sent before (the reply's ping) is read
        if not await client.read_some(0.1):
            break
    pings = len(client.pings)
    assert not await client.read_some(WATCH_EVERY * 5)  # five watch periods: nothing at all
    assert len(client.pings) == pings and not tick.running
    await pub.send({"op": "publish", "topic": POSE, "msg": {"data": "quiet-1"}})
    await client.read_until("quiet-1", max_bytes=1 << 16)
    assert tick.running
    loop = asyncio.get_running_loop()
    deadline = loop.time() + 5.0
    while len(client.pings) == pings and loop.time() < deadline:  # a ping follows the bytes
        await client.read_some(deadline - loop.time())
    assert len(client.pings) > pings
    await until(lambda: not tick.running, "the tick stopping again", 5)
    client.close()
    await pub.close()

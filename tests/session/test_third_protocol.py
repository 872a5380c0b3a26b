"""A third wire protocol is its own package plus one registration line (ARCHITECTURE.md,
"Inside session/"): the test-only line protocol (tests/session/lines/) is served by a real
server over real WebSockets, beside rosbridge clients on the same topic; its encoding is a key
of its own in the message's memo, made once per message for all its clients, and nothing of
wire/ or of the other sessions knows it."""

from __future__ import annotations

import ast
import asyncio
from pathlib import Path

from websockets.asyncio.client import connect

from tests.helpers import WsClient, round_trip
from tests.session.lines.session import SUBPROTOCOL, Lines

LINES = Path(__file__).parent / "lines"


async def test_a_third_protocol_is_its_package_and_one_registration_line(server):
    lines = Lines(server.bus)
    server.protocols.register([SUBPROTOCOL], lines.open)  # the one registration line
    publisher = await WsClient.open(server.port)
    listener = await WsClient.open(server.port)  # a rosbridge subscriber of the same topic
    url = f"ws://127.0.0.1:{server.port}"
    first = await connect(url, subprotocols=[SUBPROTOCOL])
    second = await connect(url, subprotocols=["x.unknown", SUBPROTOCOL])
    try:
        assert first.subprotocol == second.subprotocol == SUBPROTOCOL
        await publisher.send({"op": "advertise", "topic": "/chatter", "type": "std_msgs/String"})
        await listener.send({"op": "subscribe", "topic": "/chatter", "type": "std_msgs/String"})
        await round_trip(publisher)
        await round_trip(listener)
        await first.send("hello")
        assert (await asyncio.wait_for(first.recv(), 5)).startswith("error expected 'subscribe")
        for ws in (first, second):
            await ws.send("subscribe /chatter std_msgs/String")
            assert await asyncio.wait_for(ws.recv(), 5) == "subscribed /chatter"
        for i in range(3):
            await publisher.send({"op": "publish", "topic": "/chatter", "msg": {"data": f"m{i}"}})
        for ws in (first, second):
            got = [await asyncio.wait_for(ws.recv(), 5) for _ in range(3)]
            assert got == [f'/chatter {{"data":"m{i}"}}' for i in range(3)]
        for i in range(3):
            op = await listener.expect(op="publish", topic="/chatter")
            assert op["msg"] == {"data": f"m{i}"}
        assert len(lines.made) == 3 == len(set(lines.made))  # one line a message, both clients
    finally:
        for ws in (first, second):
            await ws.close()
        await publisher.close()
        await listener.close()


def imports_of(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            found.add(node.module)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return found


def test_the_third_protocol_needs_no_other_protocol():
    """The line protocol reaches the server's floors only through the bus (its messages' memo)
    and the outbox: no rosbridge or Foxglove module, no encoder of protocol/."""
    used = set().union(*(imports_of(path) for path in LINES.glob("*.py")))
    ours = {name for name in used if name.startswith("hitrobot_server")}
    assert "hitrobot_server.bus.topics" in ours
    assert not {name for name in ours if name.startswith((
        "hitrobot_server.session.rosbridge", "hitrobot_server.session.foxglove",
        "hitrobot_server.protocol"))}, ours

"""rosauth MAC authentication on WebSocket and TCP."""

from __future__ import annotations

import asyncio
import hashlib
import json
import time

import pytest

from tests.helpers import TcpClient, WsClient

SECRET = "0123456789abcdef"


def auth_op(level: str = "admin", t: float | None = None, secret: str = SECRET,
            rand: str = "r4nd") -> dict:
    t = int(time.time() if t is None else t)
    end = t + 60
    mac = hashlib.sha512(
        f"{secret}127.0.0.1127.0.0.1{rand}{t}{level}{end}".encode()).hexdigest()
    return {"op": "auth", "mac": mac, "client": "127.0.0.1", "dest": "127.0.0.1",
            "rand": rand, "t": t, "level": level, "end": end}


@pytest.fixture
async def auth_server(make_server, tmp_path):
    secret = tmp_path / "secret"
    secret.write_text(SECRET + "\n")
    return await make_server(authenticate=True, auth_secret_file=str(secret))


async def test_valid_auth_then_ops_work_and_level_is_kept(auth_server):
    c = await WsClient.open(auth_server.port)
    await c.send(auth_op("admin"))
    reply = await c.call("/rosapi/get_time")
    assert reply["result"] is True
    session = next(iter(auth_server.sessions))
    assert session.auth_level == "admin"


async def test_op_before_auth_closes_connection(auth_server):
    c = await WsClient.open(auth_server.port)
    await c.send({"op": "call_service", "id": "x", "service": "/rosapi/get_time"})
    status = await c.expect(op="status", id="x")
    assert "auth" in status["msg"]
    await asyncio.wait_for(c.ws.wait_closed(), 3)


@pytest.mark.parametrize("bad", [
    lambda: auth_op(secret="fedcba9876543210"),
    lambda: auth_op(t=time.time() - 30),
    lambda: {**auth_op(), "mac": auth_op()["mac"].upper()},
    lambda: json.dumps(auth_op()).replace('"end": ', '"end": NaN, "x": '),
], ids=["wrong-secret", "expired", "uppercase-mac", "nan-end"])
async def test_bad_auth_closes(auth_server, bad):
    c = await WsClient.open(auth_server.port)
    await c.send(bad())
    await c.expect(op="status", level="error")
    await asyncio.wait_for(c.ws.wait_closed(), 3)


async def test_auth_over_tcp(auth_server):
    c = await TcpClient.open(auth_server.tcp_port)
    await c.send(auth_op("user"))
    await c.send({"op": "call_service", "id": "t", "service": "/rosapi/get_time"})
    reply = await c.expect(op="service_response", id="t")
    assert reply["result"] is True
    await c.close()


async def test_published_messages_carry_the_publishers_auth_level(auth_server):
    from hitrobot_server.nodes.base import Node

    node = Node(auth_server.bus, "/auth_probe")
    got = []
    node.subscribe("/probe", "std_msgs/String", got.append)
    c = await WsClient.open(auth_server.port)
    await c.send(auth_op("operator"))
    await c.send({"op": "publish", "topic": "/probe", "msg": {"data": "x"}})
    await c.call("/rosapi/get_time")  # ops are handled in order: the publish is done
    assert got and got[0].origin.auth_level == "operator"
    assert got[0].origin.node.startswith("/hitrobot_client_")


async def test_a_replayed_auth_op_is_refused_on_any_connection(auth_server):
    """Each MAC grants access once, server-wide: a captured op replayed within its time window
    (on WebSocket or TCP) closes that connection, and the first login keeps working."""
    op = auth_op("admin")
    first = await WsClient.open(auth_server.port)
    await first.send(op)
    assert (await first.call("/rosapi/get_time"))["result"] is True
    again = await WsClient.open(auth_server.port)
    await again.send({**op, "id": "replay"})
    status = await again.expect(op="status", id="replay")
    assert status["level"] == "error" and "already used" in status["msg"]
    await asyncio.wait_for(again.ws.wait_closed(), 3)
    tcp = await TcpClient.open(auth_server.tcp_port)
    await tcp.send({**op, "id": "replay-tcp"})
    status = await tcp.expect(op="status", id="replay-tcp")
    assert "already used" in status["msg"]
    assert await asyncio.wait_for(tcp.reader.read(), 3) == b""  # closed by the server
    fresh = await TcpClient.open(auth_server.tcp_port)
    await fresh.send(auth_op("user", rand="other"))
    await fresh.send({"op": "call_service", "id": "t", "service": "/rosapi/get_time"})
    assert (await fresh.expect(op="service_response", id="t"))["result"] is True
    assert (await first.call("/rosapi/get_time"))["result"] is True
    await first.close()
    await fresh.close()


async def test_invalid_json_before_auth_closes_the_connection(auth_server):
    c = await WsClient.open(auth_server.port)
    await c.send("{not json")
    status = await c.expect(op="status", level="error")
    assert "not authenticated" in status["msg"]
    await asyncio.wait_for(c.ws.wait_closed(), 3)


async def test_garbage_before_auth_closes_a_tcp_connection(auth_server):
    c = await TcpClient.open(auth_server.tcp_port)
    await c.send_bytes(b"hello?\n")
    status = await c.expect(op="status")
    assert status["level"] == "error" and "not authenticated" in status["msg"]
    assert await asyncio.wait_for(c.reader.read(), 3) == b""


@pytest.mark.parametrize(("level", "role"), [("admin", "admin"), ("user", "operator")])
async def test_a_rosauth_level_maps_to_a_role(auth_server, level, role):
    """Issue 47: rosauth keeps working; ``admin`` is the admin role, any other level
    operator (who may not publish /cmd_string)."""
    c = await WsClient.open(auth_server.port)
    await c.send(auth_op(level, rand=f"r-{level}"))
    who = json.loads((await c.call("/hitrobot/whoami"))["values"]["message"])
    assert who["role"] == role and who["name"] == "rosauth:127.0.0.1"
    await c.send({"op": "publish", "id": "p", "topic": "/cmd_string", "msg": {"data": "x"}})
    await c.send({"op": "call_service", "id": "s", "service": "/rosapi/get_time"})
    statuses = []
    while True:
        message = await c.recv()
        if message.get("id") == "s":
            break
        statuses.append(message)
    refused = [s for s in statuses if "lacks the permission 'shell'" in s.get("msg", "")]
    assert bool(refused) == (role != "admin")
    await c.close()


async def test_an_auth_op_with_neither_a_token_nor_a_whole_mac_closes(auth_server):
    c = await WsClient.open(auth_server.port)
    await c.send({"op": "auth", "mac": "m", "id": "a"})
    status = await c.expect(op="status", id="a")
    assert "give 'token'" in status["msg"] and "client" in status["msg"]
    await asyncio.wait_for(c.ws.wait_closed(), 3)

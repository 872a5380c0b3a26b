"""rosauth MAC authentication on WebSocket and TCP."""

from __future__ import annotations

import asyncio
import hashlib
import time

import pytest

from ..helpers import TcpClient, WsClient

SECRET = "0123456789abcdef"


def auth_op(level: str = "admin", t: float | None = None, secret: str = SECRET) -> dict:
    t = int(time.time() if t is None else t)
    end = t + 60
    mac = hashlib.sha512(
        f"{secret}127.0.0.1127.0.0.1r4nd{t}{level}{end}".encode()).hexdigest()
    return {"op": "auth", "mac": mac, "client": "127.0.0.1", "dest": "127.0.0.1",
            "rand": "r4nd", "t": t, "level": level, "end": end}


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
], ids=["wrong-secret", "expired", "uppercase-mac"])
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

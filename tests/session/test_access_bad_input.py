"""Issue 47 item 7 and item 5 against a real server process (``--authenticate``, recording):
wrong, expired and revoked tokens, a 64 kB token, 10,000 wrong tokens in a row beside a
witness client, a token on a server without ``--authenticate``; every accepted change audited
by name and role; no token in the log, /metrics or the recording."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
import threading
import time

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed, InvalidStatus

from hitrobot_server.record.profile import AUDIT_TOPIC
from hitrobot_server.state.tokens import add_token, tokens_path
from tests.helpers import ServerProcess, WsClient

FLOOD = 10_000


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    state = tmp_path_factory.mktemp("state")
    folder = tmp_path_factory.mktemp("recordings")
    tokens = {
        "operator": add_token(tokens_path(state), "tablet-1", "operator", None),
        "viewer": add_token(tokens_path(state), "hall-screen", "viewer", None),
        "monitor": add_token(tokens_path(state), "prometheus", "monitor", None),
        "expired": add_token(tokens_path(state), "old", "admin", time.time() - 1),
        "revoked": add_token(tokens_path(state), "gone", "admin", None),
    }
    recording = folder / "audit.mcap"
    proc = ServerProcess("--authenticate", "--state-dir", str(state), "--record",
                         str(recording), "--record-dir", str(folder), "--map-dir",
                         str(folder / "maps"), robot="sim")
    drain = threading.Thread(target=lambda: proc.output.extend(proc.proc.stdout), daemon=True)
    drain.start()  # the server's log read as it comes (a full pipe would stop it)
    yield {"proc": proc, "tokens": tokens, "state": state, "recording": recording,
           "drain": drain}
    proc.stop()


async def refused_at_upgrade(port: int, token: str) -> str:
    try:
        async with connect(f"ws://127.0.0.1:{port}/?token={token}"):
            raise AssertionError("the upgrade was accepted")
    except InvalidStatus as exc:
        assert exc.response.status_code == 401
        return exc.response.body.decode()


async def test_wrong_expired_and_revoked_tokens_are_refused_at_the_upgrade(site):
    proc, tokens = site["proc"], site["tokens"]
    assert "unknown or revoked token" in await refused_at_upgrade(proc.port, "not-a-token")
    assert "token 'old' expired" in await refused_at_upgrade(proc.port, tokens["expired"])
    async with connect(f"ws://127.0.0.1:{proc.port}/?token={tokens['revoked']}"):
        pass  # good until revoked
    out = subprocess.run([sys.executable, "-m", "hitrobot_server", "token", "revoke", "gone",
                          "--state-dir", str(site["state"])], capture_output=True, timeout=60)
    assert out.returncode == 0
    deadline = time.monotonic() + 5  # the server looks at the file at most once a second
    while True:
        try:
            body = await refused_at_upgrade(proc.port, tokens["revoked"])
            break
        except AssertionError:
            assert time.monotonic() < deadline, "the revoked token still works"
            await asyncio.sleep(0.2)
    assert "unknown or revoked token" in body


async def test_a_wrong_token_in_an_auth_op_closes_with_the_reason(site):
    proc = site["proc"]
    client = await WsClient.open(proc.port)
    await client.send({"op": "auth", "token": "wrong", "id": "a"})
    status = await client.recv()
    assert status["op"] == "status" and status["level"] == "error" and status["id"] == "a"
    assert "token refused: unknown or revoked token; closing" in status["msg"]
    with pytest.raises(ConnectionClosed):
        await client.recv()


async def test_the_token_as_the_first_line_of_tcp(site):
    proc = site["proc"]
    await _wait_tcp_port(proc)
    reader, writer = await asyncio.open_connection("127.0.0.1", proc.tcp_port)
    writer.write(json.dumps({"op": "auth", "token": site["tokens"]["viewer"]}).encode() + b"\n")
    writer.write(b'{"op": "call_service", "service": "/hitrobot/whoami", "id": "w"}\n')
    answer = json.loads(await asyncio.wait_for(reader.readline(), 10))
    assert answer["op"] == "service_response" and answer["id"] == "w"
    assert json.loads(answer["values"]["message"])["name"] == "hall-screen"
    writer.close()


async def _wait_tcp_port(proc: ServerProcess) -> None:
    deadline = time.monotonic() + 10
    while proc.tcp_port is None:
        for line in proc.output:
            if "tcp://" in line:
                proc.tcp_port = int(line.rsplit(":", 1)[1])
        assert time.monotonic() < deadline
        await asyncio.sleep(0.05)


@pytest.mark.parametrize("path", ["/metrics?token=", "/?token="])
async def test_a_64_kb_token_in_the_url_is_refused_cleanly(site, path):
    proc = site["proc"]
    reader, writer = await asyncio.open_connection("127.0.0.1", proc.port)
    upgrade = ("Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Version: 13\r\n"
               "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n") if path == "/?token=" else ""
    writer.write(f"GET {path}{'A' * 65536} HTTP/1.1\r\nHost: x\r\n{upgrade}\r\n".encode())
    head = await asyncio.wait_for(reader.read(200), 10)
    writer.close()
    status = int(head.split(b" ", 2)[1])
    assert 400 <= status < 500, head
    async with connect(f"ws://127.0.0.1:{proc.port}/?token={site['tokens']['viewer']}"):
        pass  # the server goes on


async def test_ten_thousand_wrong_tokens_in_bounded_time_beside_a_witness(site):
    """Wrong tokens are not slowed down (they cannot be guessed); each costs a hash. The
    flood ends in bounded time and a witness's round trips stay prompt meanwhile; the log gets
    at most about a line a second for them."""
    proc, tokens = site["proc"], site["tokens"]
    witness = await WsClient.open(proc.port, additional_headers={
        "Authorization": f"Bearer {tokens['viewer']}"})
    lines_before = len(proc.output)
    refused = 0

    async def one(i: int) -> None:
        nonlocal refused
        reader, writer = await asyncio.open_connection("127.0.0.1", proc.port)
        writer.write(f"GET /metrics HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer wrong{i}"
                     "\r\n\r\n".encode())
        head = await asyncio.wait_for(reader.read(64), 10)
        writer.close()
        refused += head.startswith(b"HTTP/1.1 401")

    async def flood() -> None:
        for start in range(0, FLOOD, 50):
            await asyncio.gather(*(one(i) for i in range(start, start + 50)))

    started = time.monotonic()
    task = asyncio.ensure_future(flood())
    times: list[float] = []
    while not task.done():
        t0 = time.monotonic()
        await witness.send({"op": "call_service", "service": "/rosapi/get_time",
                            "id": f"w{len(times)}"})
        reply = await witness.recv(timeout=10)
        assert reply["op"] == "service_response" and reply["result"]
        times.append(time.monotonic() - t0)
        await asyncio.sleep(0.05)
    await task
    took = time.monotonic() - started
    await witness.close()
    times.sort()
    print(f"\n{FLOOD} wrong tokens in {took:.1f} s; witness: {len(times)} round trips, "
          f"median {times[len(times) // 2]:.3f} s, worst {times[-1]:.3f} s")
    assert refused == FLOOD and took < 300
    assert times[-1] < 3.0 and len(times) > 1
    logged = [line for line in proc.output[lines_before:] if "token refused" in line]
    assert len(logged) <= took + 5, len(logged)


async def test_z_the_audit_names_who_changed_and_no_token_leaks(site):
    """Last (z): an operator's accepted change and a viewer's refused one; then the log, a
    /metrics scrape and the recording are searched for every token."""
    proc, tokens = site["proc"], site["tokens"]
    op = await WsClient.open(proc.port, additional_headers={
        "Authorization": f"Bearer {tokens['operator']}"})
    await op.send({"op": "call_service", "service": "/planning/clear_waypoints", "id": "c"})
    assert (await op.recv(timeout=10))["result"]
    await op.close()
    viewer = await WsClient.open(proc.port)
    await viewer.send({"op": "auth", "token": tokens["viewer"]})
    await viewer.send({"op": "publish", "topic": "/cmd_vel", "id": "p",
                       "msg": {"linear": {"x": 0.1}}})
    status = await viewer.recv(timeout=10)
    assert "role 'viewer' lacks the permission 'drive'" in status["msg"]
    await viewer.close()
    reader, writer = await asyncio.open_connection("127.0.0.1", proc.port)
    writer.write(f"GET /metrics?token={tokens['monitor']} HTTP/1.1\r\nHost: x\r\n\r\n".encode())
    scrape = await asyncio.wait_for(reader.read(), 10)
    writer.close()
    assert b"200 OK" in scrape.split(b"\r\n", 1)[0]
    proc.stop()
    site["drain"].join(10)
    log = "".join(proc.output)
    recording = site["recording"].read_bytes()
    for token in tokens.values():
        assert token not in log and token.encode() not in scrape + recording
    assert "refused hall-screen" in log  # the refusal, by name (it reached /rosout too)
    with open(site["recording"], "rb") as f:
        audit = [m for _s, ch, _m, m in make_reader(
            f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()
            if ch.topic == AUDIT_TOPIC]
    assert [(a.name, a.token_name, a.role) for a in audit
            if a.name == "/planning/clear_waypoints"] == [
        ("/planning/clear_waypoints", "tablet-1", "operator")]
    assert not [a for a in audit if a.name == "/cmd_vel"]  # refused: nothing happened


async def test_a_token_on_a_server_without_authenticate_is_ignored(make_server):
    """Accepted and ignored: every client is admin there (the token is not even looked up)."""
    server = await make_server()
    client = await WsClient.open(server.port, additional_headers={
        "Authorization": "Bearer whatever"})
    await client.send({"op": "call_service", "service": "/hitrobot/whoami", "id": "w"})
    who = json.loads((await client.recv())["values"]["message"])
    assert who["role"] == "admin" and not who["authenticate"]
    await client.send({"op": "set_level", "level": "info"})
    assert "status level set to info" in (await client.recv())["msg"]
    await client.send({"op": "auth", "token": "whatever", "id": "a"})
    status = await client.recv()
    assert status["level"] == "info" and "not enabled; ignored" in status["msg"]
    await client.close()

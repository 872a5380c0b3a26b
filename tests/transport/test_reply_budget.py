"""Issue 27, item 1: a client that asks for replies and never reads them holds a bounded number
of bytes in the server, cannot slow anyone else down, and frees them the moment it leaves."""

from __future__ import annotations

import asyncio
import json
import socket
import time
from pathlib import Path

import pytest
from websockets.asyncio.client import connect

from hitrobot_server.nodes.base import Node
from tests.helpers import TcpClient, until
from tests.witness import Witness

BUDGET = 1_000_000  # --reply-buffer-limit of the test server
REPLY = 200_000  # bytes of each reply of /big_reply (the sync_get_stcm: 205 kB)


def rss() -> int:
    """This process's resident set (the server runs in it), in bytes."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmRSS in /proc/self/status")


def newest(server):
    return max(server.sessions, key=lambda s: s.client_id)


async def tcp_session(server):
    await until(lambda: any(s.transport == "tcp" for s in server.sessions), "TCP session")
    return next(s for s in server.sessions if s.transport == "tcp")


async def witness_round_trips(witness: Witness, count: int) -> float:
    """The slowest of ``count`` service round trips of the witness, in seconds."""
    worst = 0.0
    for _ in range(count):
        start = time.monotonic()
        reply = await witness.sub.call("/rosapi/get_time", timeout=5)
        assert reply["result"] is True
        worst = max(worst, time.monotonic() - start)
    return worst


@pytest.fixture
async def big_server(make_server):
    server = await make_server(reply_buffer_limit=BUDGET)
    node = Node(server.bus, "/big_replies")
    body = "r" * REPLY

    async def handler(_request: dict) -> dict:
        return {"success": True, "message": body}

    node.service("/big_reply", "std_srvs/Trigger", handler)
    return server


async def test_reply_amplification_is_bounded_and_freed_at_once(big_server):
    server = big_server
    witness = await Witness.open(server.port)
    await witness.check()
    attacker = await connect(f"ws://127.0.0.1:{server.port}", max_size=None, max_queue=1)
    before = rss()
    attacker.transport.pause_reading()  # it never reads a reply
    calls = 400  # 80 MB of replies if the server held them all
    for i in range(calls):
        await attacker.send(json.dumps({"op": "call_service", "id": f"a{i}",
                                        "service": "/big_reply"}))
    session = newest(server)

    def stopped() -> bool:  # backpressure, or closed past the hard bound
        return not session.outbox.room.is_set() or session.closed or session.outbox.closed

    await until(stopped, "the attacker held back", timeout=20)
    assert await witness_round_trips(witness, 10) <= 0.5
    await witness.publish(20)
    await witness.check()
    assert session.outbox.control_bytes <= 2 * BUDGET + REPLY + 1000
    assert rss() - before < 60_000_000  # not the 80 MB the calls ask for
    if session.outbox.closed:  # past the hard bound: closed, with the reason it is told
        assert "--reply-buffer-limit" in session.close_reason
    attacker.transport.abort()  # it leaves without reading anything
    await until(lambda: session.closed, "the attacker's session closed", timeout=10)
    assert session.outbox.buffered == 0 and len(session.outbox) == 0  # freed, not at a GC
    assert session not in server.sessions
    await witness.check()
    await witness.close()


async def test_requests_over_the_budget_are_refused_never_dropped(big_server):
    """Over TCP one read holds many calls: those past the budget get a failed reply saying
    why, and every call gets exactly one answer."""
    server = big_server
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 32 * 1024)  # little in the kernel
    sock.connect(("127.0.0.1", server.tcp_port))
    sock.setblocking(False)
    client = TcpClient(*await asyncio.open_connection(sock=sock, limit=2**26))
    calls = 60  # 12 MB of replies asked for at once, against a 1 MB budget
    client.writer.transport.pause_reading()  # it reads nothing until all calls are sent
    first = b"".join(json.dumps({"op": "call_service", "id": f"c{i}",
                                 "service": "/big_reply"}).encode() for i in range(8))
    await client.send_bytes(first)
    session = await tcp_session(server)
    await until(lambda: session.outbox.control_bytes > BUDGET, "replies queued", timeout=10)
    rest = b"".join(json.dumps({"op": "call_service", "id": f"c{i}",
                                "service": "/big_reply"}).encode() for i in range(8, calls))
    await client.send_bytes(rest)
    client.writer.transport.resume_reading()
    answers: dict[str, bool] = {}
    refused = 0
    deadline = time.monotonic() + 30
    while len(answers) < calls and time.monotonic() < deadline:
        msg = await client.recv(timeout=10)
        if msg.get("op") == "service_response":
            assert msg["id"] not in answers, f"two answers for {msg['id']}"
            answers[msg["id"]] = msg["result"]
            if not msg["result"]:
                assert "too many requests in flight" in msg["values"]
                refused += 1
    assert sorted(answers) == sorted(f"c{i}" for i in range(calls))
    assert answers["c0"] is True and refused > 0
    assert not session.outbox.closed  # a client that reads is refused, never disconnected
    await client.close()


async def test_a_flood_of_bogus_ops_queues_a_bounded_number_of_error_statuses(big_server):
    server = big_server
    witness = await Witness.open(server.port)
    client = await TcpClient.open(server.tcp_port)
    client.writer.transport.pause_reading()  # it never reads
    junk = b'{"op":"no_such_op"}' * 20_000
    await client.send_bytes(junk)
    session = await tcp_session(server)
    await until(lambda: session.limits._errors_skipped > 0, "errors left out", timeout=20)
    assert await witness_round_trips(witness, 5) <= 0.5
    assert session.outbox.control_bytes < 200_000  # not the ~2 MB of 20,000 statuses
    await client.close()
    await witness.check()
    await witness.close()

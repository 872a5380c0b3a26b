"""What hostile clients can make the server hold, measured as a whole (the server's RSS plus its
worker processes', from /proc) on a real server process: pending calls are capped and their
memory is reused once the caller leaves; a CBOR typed-array bomb costs a few times its size,
not one Python object per byte. Each attack is scaled down; a witness loses nothing."""

from __future__ import annotations

import asyncio

import cbor2
import numpy as np
import pytest

from hitrobot_server import procmem
from tests.helpers import ServerProcess, WsClient, silent_provider
from tests.witness import Witness

pytestmark = pytest.mark.hostile

MB = 2**20
CAP = 500


@pytest.fixture
def server():
    # warning: a flood of refusals must not fill the (unread) stdout pipe with info lines
    proc = ServerProcess("--max-requests-in-flight", str(CAP), "--log-level", "warning")
    yield proc
    proc.stop()


def total(server: ServerProcess) -> int:
    return procmem.memory(server.proc.pid).total


async def flood_calls(port: int, count: int, tag: str) -> tuple[WsClient, int]:
    """``count`` calls to a service that never answers; returns the caller and how many of
    them were refused for the cap (read as raw text: thousands of replies, parsed cheaply)."""
    caller = await WsClient.open(port)
    for i in range(count):
        await caller.send({"op": "call_service", "id": f"{tag}{i}", "service": "/mute"})
    await caller.send({"op": "call_service", "id": "end", "service": "/rosapi/get_time"})
    refused = 0
    while True:
        frame = await asyncio.wait_for(caller.ws.recv(), 30)
        if '"service_response"' in frame and "too many requests in flight" in frame:
            refused += 1
            if '"id":"end"' in frame:
                return caller, refused


async def test_pending_calls_are_capped_and_their_memory_is_reused(server):
    witness = await Witness.open(server.port)
    provider = await silent_provider(server.port)
    base = total(server)
    growth = []
    for round_ in range(3):
        caller, refused = await flood_calls(server.port, 4 * CAP, f"r{round_}-")
        assert refused == 3 * CAP + 1  # and the sentinel: the cap counts every call
        await witness.check()
        await caller.close()
        await witness.check()  # a round trip after the close: the caller is gone
        growth.append(total(server) - base)
    assert growth[0] < 30 * MB, growth  # 500 calls in flight and 1,500 refusals
    assert growth[2] - growth[0] < 4 * MB, growth  # later rounds reuse what the first freed
    provider.ws.transport.abort()  # it never read its 1,500 requests: no close handshake
    await witness.close()


async def test_a_typed_array_bomb_costs_a_few_times_its_size(server):
    witness = await Witness.open(server.port)
    client = await WsClient.open(server.port)
    await client.send({"op": "advertise", "topic": "/arr", "type": "std_msgs/Int8MultiArray"})

    def frame(size: int) -> bytes:
        return cbor2.dumps({"op": "publish", "topic": "/arr",
                            "msg": {"data": cbor2.CBORTag(72, b"\x80" * size)}})

    await client.ws.send(frame(300_000))  # starts the worker pool (a big op goes there)
    assert (await client.call("/rosapi/get_time"))["result"] is True
    workers = procmem.children(server.proc.pid)
    assert workers
    peaks = {pid: procmem.peak_bytes(pid) for pid in [server.proc.pid, *workers]}
    bomb = 8 * MB  # was one Python int per byte in the worker: 56x, +450 MB
    await client.ws.send(frame(bomb))
    assert (await client.call("/rosapi/get_time", timeout=30))["result"] is True
    for pid, before in peaks.items():
        assert procmem.peak_bytes(pid) - before < 10 * bomb, pid
    await witness.check()
    await client.close()
    await witness.close()


async def test_a_10_mb_typed_array_for_a_json_subscriber_costs_the_worker_under_10x(server):
    """Issue 36, item 5: the worker decodes the CBOR frame and builds the subscriber's JSON
    (random float32 values: widened to float64 their text was 5x the frame, held twice); its
    peak stays within ten times the frame (was 17-21x)."""
    client = await WsClient.open(server.port)
    sub = await WsClient.open(server.port)
    await client.send({"op": "advertise", "topic": "/arr", "type": "std_msgs/Float32MultiArray"})
    await sub.send({"op": "subscribe", "topic": "/arr", "type": "std_msgs/Float32MultiArray"})
    assert (await sub.call("/rosapi/get_time"))["result"] is True  # subscribed

    def frame(size: int) -> bytes:
        values = np.random.default_rng(7).random(size // 4, dtype=np.float32)
        return cbor2.dumps({"op": "publish", "topic": "/arr",
                            "msg": {"data": cbor2.CBORTag(85, values.tobytes())}})

    await client.ws.send(frame(400_000))  # starts the worker pool
    await sub.expect(op="publish", topic="/arr", timeout=60)
    workers = procmem.children(server.proc.pid)
    assert workers
    peaks = {pid: procmem.peak_bytes(pid) for pid in workers}
    size = 10 * MB
    await client.ws.send(frame(size))
    got = await sub.expect(op="publish", topic="/arr", timeout=60)
    assert len(got["msg"]["data"]) == size // 4
    grown = max(procmem.peak_bytes(pid) - before for pid, before in peaks.items())
    assert grown <= 10 * size, grown / size
    await client.close()
    await sub.close()

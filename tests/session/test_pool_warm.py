"""The first subscriber to a big message waits for no spawn (issue 49 item 6): a server whose
robot publishes a big map spawns its worker pool as it starts, before any client, and while
the pool warms up big ops are built on the loop rather than waiting for it."""

from __future__ import annotations

import asyncio
import os
import time

import orjson

from hitrobot_server.procmem import children
from hitrobot_server.protocol.bulk import OFFLOAD_BYTES
from hitrobot_server.session.offload import WorkerPool
from tests.helpers import WsClient

WARM = 60.0  # seconds a warm-up may take on a loaded machine


async def test_a_robots_server_has_its_pool_before_the_first_client(make_server):
    """The pool's process exists once ``start`` returns; the first JSON subscriber's big
    ``/map`` comes without any process spawned on its way, and no other process serves it
    once the pool is warm."""
    server = await make_server(robot="sim")
    assert server.pool.started
    spawned = set(children(os.getpid()))
    assert spawned, "the pool's process is there before any client"
    client = await WsClient.open(server.port)
    try:
        await client.send({"op": "subscribe", "id": "m", "topic": "/map"})
        first = await client.expect(op="publish", topic="/map", timeout=30)
        assert len(orjson.dumps(first)) >= OFFLOAD_BYTES  # a message the pool builds
        assert set(children(os.getpid())) <= spawned  # nothing spawned for it
        pids = await server.pool.warmed(WARM)
        assert pids and set(pids) <= spawned
    finally:
        await client.close()


async def test_a_server_without_a_robot_spawns_no_pool(make_server):
    """No big map to serve: the pool starts on first need, as before."""
    server = await make_server(robot="none")
    assert not server.pool.started
    assert await server.pool.warmed(WARM) == []


async def test_a_warming_pool_builds_here_and_in_its_process_once_warm():
    pool = WorkerPool(workers=1)
    try:
        pool.warm("hitrobot_server.protocol.bulk")
        assert pool.started
        assert await pool.run(os.getpid) == os.getpid()  # warming: built here, no wait
        (warmed,) = await pool.warmed(WARM)
        assert warmed in children(os.getpid())
        assert await pool.run(os.getpid) == warmed
    finally:
        pool.shutdown()
    assert await pool.warmed(WARM) == []


async def test_a_warmed_pool_stopped_when_idle_comes_back_warm():
    """The idle stop gives the used processes back and warms fresh ones at once."""
    pool = WorkerPool(workers=1, idle_stop=0.3)
    try:
        pool.warm()
        (first,) = await pool.warmed(WARM)
        assert await pool.run(os.getpid) == first  # used: the idle stop is armed
        deadline = time.monotonic() + WARM
        while first in children(os.getpid()) and time.monotonic() < deadline:
            await asyncio.sleep(0.05)  # polling the process table, bounded
        assert first not in children(os.getpid())
        (second,) = await pool.warmed(WARM)
        assert second != first and second in children(os.getpid())
    finally:
        pool.shutdown()

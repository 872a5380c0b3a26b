"""Issue 52, item 5: WebSocket control frames cost what data frames cost. A raw client that
floods pings and never reads the pongs is slowed to a bounded rate, holds a bounded number of
bytes in the server, and costs the other clients nothing; a client that pings now and then gets
every pong (tests of the count alone: the sans-I/O ``ControlBudget``)."""

from __future__ import annotations

import asyncio
import sys
import time

import pytest
from websockets.asyncio.client import connect

from hitrobot_server.session.core import BEHIND_BYTES, CONTROL_FRAMES_PER_SECOND
from hitrobot_server.transport.control import ControlBudget
from tests.helpers import ServerProcess
from tests.nodes.fleet.test_restart import cpu_seconds
from tests.witness import MemoryPeak, RoundTrips

FLOOD_SECONDS = 3.0


def test_the_budget_counts_the_rate_and_the_pongs_unread():
    budget = ControlBudget()
    assert not any(budget.frame(10.0, 6) for _ in range(CONTROL_FRAMES_PER_SECOND))
    assert budget.frame(10.5, 6)  # one more within the second
    assert not budget.frame(11.0, 6)  # a new second
    assert not budget.behind(10 * BEHIND_BYTES)  # 606 bytes of pongs: not behind
    budget.frame(11.1, BEHIND_BYTES)
    assert budget.behind(10 * BEHIND_BYTES) and not budget.behind(1000)  # the buffer decides
    budget.drained()
    assert not budget.behind(10 * BEHIND_BYTES)


@pytest.mark.serial  # the witness's bound and the CPU share: run alone (tests/run.py)
async def test_a_ping_flood_is_slowed_bounded_and_costs_the_others_nothing():
    server = ServerProcess()
    try:
        async with connect(f"ws://127.0.0.1:{server.port}") as polite:
            for _ in range(20):  # a client that pings now and then gets every pong
                await (await polite.ping())
        memory = MemoryPeak(server.proc.pid)
        witness = await RoundTrips.open(server.port)
        before, began = cpu_seconds(server.proc.pid), time.monotonic()
        flooder = await asyncio.create_subprocess_exec(  # the witness measures meanwhile
            sys.executable, "-m", "tests.transport.pingflood", str(server.port),
            str(FLOOD_SECONDS), stdout=asyncio.subprocess.PIPE)
        out, _ = await asyncio.wait_for(flooder.communicate(), FLOOD_SECONDS + 30)
        share = (cpu_seconds(server.proc.pid) - before) / (time.monotonic() - began)
        grew = memory.stop()
        worst = await witness.stop()
        # the server read a few kB a second of it (the rest waits in the kernel's buffers)
        assert share < 0.3, f"{share:.0%} of a core while flooded"
        assert grew < 50_000_000, f"+{grew / 1e6:.0f} MB"
        assert worst <= 0.5, witness.times
        assert int(out) > 0
    finally:
        server.stop()

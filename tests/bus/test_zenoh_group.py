"""The bus's site-wide role over real Zenoh sessions on loopback (two links in this process):
the first to join leads and a later one follows it, changes reach the follower and are
refused from a process it does not follow, a follower fetches the leader's state, and when the
leader leaves the follower leads."""

from __future__ import annotations

import asyncio

import pytest

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.errors import ServiceError
from hitrobot_server.bus.zenoh.link import ZenohLink
from hitrobot_server.types.registry import TypeRegistry
from tests.bus.test_zenoh_scale_out import free_port


class Member:
    """What one process keeps of the group: its roles, the changes it applied."""

    def __init__(self, state: bytes):
        self.state = state
        self.leaders: list[str] = []
        self.applied: list[bytes] = []
        self.changed = asyncio.Event()

    def role(self, leader: str) -> None:
        self.leaders.append(leader)
        self.changed.set()

    async def apply(self, payload: bytes) -> None:
        self.applied.append(payload)

    def snapshot(self) -> bytes:
        return self.state


async def until(predicate, member: Member, what: str, timeout: float = 10.0) -> None:
    async def wait() -> None:
        while not predicate():
            member.changed.clear()
            await member.changed.wait()

    try:
        await asyncio.wait_for(wait(), timeout)
    except TimeoutError:
        raise AssertionError(f"timed out waiting for {what}") from None


async def test_first_leads_the_other_follows_and_takes_over():
    port = free_port()
    a = ZenohLink(Bus(TypeRegistry.default()), listen=[f"tcp/127.0.0.1:{port}"])
    b = ZenohLink(Bus(TypeRegistry.default()), connect=[f"tcp/127.0.0.1:{port}"])
    await a.start()
    await b.start()
    try:
        ga, gb = a.group("fleet"), b.group("fleet")
        ma, mb = Member(b"a's board"), Member(b"b's board")
        await ga.join(ma)
        assert ma.leaders == [a.zid]  # alone: it claims
        await gb.join(mb)
        await until(lambda: mb.leaders[-1:] == [a.zid], mb, "b following a")
        # a live leader is kept, whatever the ids (b, linked late, may claim for a moment:
        # a's earlier claim wins when they meet)
        assert ma.leaders == [a.zid]

        # b's token may reach a a moment after a's reached b: until then a has no follower
        # and replicates to no one (nothing is sent); on a busy machine that moment is long
        loop = asyncio.get_running_loop()
        deadline = loop.time() + 10.0
        while not ga.members - {a.zid} and loop.time() < deadline:
            await asyncio.sleep(0.02)
        assert await ga.replicate(b"change 1", 5.0) == (1, 1)
        assert mb.applied == [b"change 1"]
        assert await gb.replicate(b"not mine", 5.0) == (0, 1)  # a follower sends nothing
        assert await gb.fetch(5.0) == b"a's board"
        with pytest.raises(ServiceError):
            await ga.fetch(5.0)  # the leader has no one to ask

        await ga.leave()
        await until(lambda: mb.leaders[-1:] == [b.zid], mb, "b taking over")
        assert await gb.replicate(b"alone", 5.0) == (0, 0)
        await gb.leave()
    finally:
        await b.stop()
        await a.stop()


async def test_two_leaders_that_meet_settle_on_the_earlier_claim():
    """A and C claim apart (not linked); B links them: the later claim steps down."""
    ports = free_port(), free_port()
    a, c = (ZenohLink(Bus(TypeRegistry.default()), listen=[f"tcp/127.0.0.1:{p}"])
            for p in ports)
    b = ZenohLink(Bus(TypeRegistry.default()),
                  connect=[f"tcp/127.0.0.1:{p}" for p in ports])
    await a.start()
    await c.start()
    try:
        ma, mc, mb = Member(b"a"), Member(b"c"), Member(b"b")
        await a.group("fleet").join(ma)
        await c.group("fleet").join(mc)
        assert (ma.leaders, mc.leaders) == ([a.zid], [c.zid])  # apart, each claims
        await b.start()
        await b.group("fleet").join(mb)
        await until(lambda: mc.leaders[-1:] == [a.zid], mc, "c following a")
        assert ma.leaders == [a.zid] and mb.leaders[-1:] == [a.zid]
    finally:
        await b.stop()
        await c.stop()
        await a.stop()

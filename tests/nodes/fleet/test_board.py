"""The fleet's board owns its state: each change is signalled (the replica listens), and
``durable()`` resolves once the changes so far are in the state folder (read back from a
reopened store) and every copy hook has them, saying what is missing."""

from __future__ import annotations

import asyncio

from hitrobot_server.nodes.fleet.board import Board
from hitrobot_server.nodes.fleet.tasks import Stop, Task
from hitrobot_server.robot.model import Pose2D
from hitrobot_server.state import StateBinding, StateStore


async def test_a_change_is_signalled_and_durable_when_on_disk_and_copied(tmp_path):
    store = StateStore.open(tmp_path / "site")
    copied = asyncio.get_running_loop().create_future()
    try:
        board = Board(StateBinding(store, "site"))
        signals: list[int] = []
        board.on_change(lambda: signals.append(len(board.tasks)))
        board.copied_by(lambda: _said(copied))
        board.add(Task(board.new_id(), "goto", [Stop("", Pose2D(1.0, 2.0, 0.0))], ""))
        assert signals and signals[-1] == 1
        kept = asyncio.ensure_future(board.durable())
        await asyncio.wait_for(board.memory.durable(), 5)  # on disk; the copy not yet
        assert not kept.done()
        copied.set_result(" (copied to 0 of the 1 other servers only)")
        assert await asyncio.wait_for(kept, 5) == " (copied to 0 of the 1 other servers only)"
    finally:
        await store.close()
    again = StateStore.open(tmp_path / "site")
    try:
        assert [r["id"] for r in again.get("fleet/open")] == [1]
    finally:
        await again.close()


async def _said(copied: asyncio.Future) -> str:
    return await copied

"""The client core both sessions hold, on a real bus: its node, its reply bound, its tasks and
what it gives back."""

from __future__ import annotations

import asyncio
import contextlib

from hitrobot_server.bus.core import Bus
from hitrobot_server.session.core import ClientCore
from hitrobot_server.session.options import SessionOptions
from hitrobot_server.types.registry import TypeRegistry


def error_frames(text: str) -> list:
    return [(f"error: {text}", False)]


async def test_the_core_names_holds_and_releases_one_client():
    bus = Bus(TypeRegistry.default(), unregister_timeout=0)
    core = ClientCore(bus, SessionOptions(), "7", "127.0.0.1:5", error_frames)
    owner = object()
    assert core.node.endswith("7") and core.node in bus.nodes
    assert core.origin.node == core.node and core.origin.peer == "127.0.0.1:5"
    bus.advertise("/core/t", "std_msgs/String", owner, core.node)
    task = core.spawn(asyncio.sleep(60))
    closed: list[object] = []
    core.on_close.append(closed.append)

    assert core.close() and not core.close()  # closed once
    core.release(owner)
    with contextlib.suppress(asyncio.CancelledError):
        await asyncio.wait_for(task, 1)
    assert task.cancelled()
    assert core.node not in bus.nodes
    assert "/core/t" not in bus.topics  # its only publisher went with the owner
    assert closed == [owner] and core.on_close == []


async def test_past_twice_the_reply_budget_the_client_is_cut_off_in_its_own_words():
    bus = Bus(TypeRegistry.default())
    core = ClientCore(bus, SessionOptions(reply_buffer_limit=1000), "1", "", error_frames)
    core.reply([("x" * 900, False)])
    assert core.replies_full() is False and core.reply_bytes > 0
    core.reply([("x" * 200, False)])
    assert core.replies_full() and not core.close_reason
    core.notice([("x" * 1000, False)])
    assert "twice --reply-buffer-limit 1000" in core.close_reason
    last = await asyncio.wait_for(core.outbox.get(), 1)
    assert last is not None and last[0][0].startswith("error: disconnected")
    core.outbox.sent()
    assert await asyncio.wait_for(core.outbox.get(), 1) is None  # nothing else, then closed

"""The bounded per-client send buffer, tested directly."""

from __future__ import annotations

import asyncio

from hitrobot_server.session.outbox import Outbox


def frames(n: int, size: int = 10) -> list[tuple[bytes, bool]]:
    return [(bytes([n]) * size, False)]


async def test_drops_oldest_topic_data_when_full_but_keeps_replies():
    box = Outbox(limit=35)
    box.put(frames(1), droppable=True)
    box.put(frames(2), droppable=False)  # a reply
    box.put(frames(3), droppable=True)
    assert box.put(frames(4), droppable=True)  # evicts 1, the oldest topic message
    assert box.dropped == 1 and box.buffered == 30
    got = [(await box.get())[0][0][0] for _ in range(3)]
    assert got == [2, 3, 4]


async def test_reply_is_never_dropped_even_over_limit():
    box = Outbox(limit=15)
    box.put(frames(1), droppable=True)
    box.put(frames(2), droppable=False)
    box.put(frames(3), droppable=False)
    assert box.buffered == 30  # replies may exceed the limit; they are small and must arrive
    assert box.dropped == 0


async def test_oversized_message_still_goes_out_when_buffer_is_empty():
    box = Outbox(limit=5)
    assert box.put(frames(7, size=100), droppable=True)
    assert box.put(frames(8, size=100), droppable=True)  # the newest big one replaces it
    assert box.dropped == 1 and len(box) == 1
    assert (await box.get())[0][0] == bytes([8]) * 100
    box.put(frames(9), droppable=False)
    assert not box.put(frames(10, size=100), droppable=True)  # a reply is queued: no room


async def test_fragment_group_stays_whole():
    box = Outbox(limit=1000)
    group = [(b"a" * 10, False), (b"b" * 10, False), (b"c" * 10, False)]
    box.put(group, droppable=True)
    assert await box.get() == group


async def test_close_drains_then_ends():
    box = Outbox()
    box.put(frames(1))
    box.close()
    assert box.put(frames(2)) is False
    assert (await box.get()) == frames(1)
    assert await box.get() is None


async def test_get_waits_for_put():
    box = Outbox()
    waiter = asyncio.ensure_future(box.get())
    await asyncio.sleep(0.01)
    assert not waiter.done()
    box.put(frames(5))
    assert await asyncio.wait_for(waiter, 1) == frames(5)


async def test_a_future_entry_holds_later_frames_until_it_resolves():
    box = Outbox(limit=1000)
    sent: list = []
    box.direct = lambda fr: sent.append(fr) or True
    future = asyncio.get_running_loop().create_future()
    assert box.put(future, droppable=True, size=100)
    assert box.buffered == 100
    box.put(frames(2))  # would be written directly, but must wait behind the future
    assert sent == [] and len(box) == 2
    getter = asyncio.ensure_future(box.get())
    await asyncio.sleep(0)
    assert not getter.done()
    future.set_result(frames(1))
    assert await getter == frames(1)
    box.sent()
    assert await box.get() == frames(2)


async def test_a_failed_or_cancelled_future_is_skipped_and_a_cancelled_get_leaves_it_alone():
    box = Outbox()
    failed = asyncio.get_running_loop().create_future()
    failed.set_exception(RuntimeError("encoder broke"))
    box.put(failed, droppable=True)
    box.put(frames(3))
    assert await box.get() == frames(3)

    shared = asyncio.get_running_loop().create_future()
    box.put(shared, droppable=True)
    getter = asyncio.ensure_future(box.get())
    await asyncio.sleep(0)
    getter.cancel()  # this client's pump goes away
    await asyncio.gather(getter, return_exceptions=True)
    assert not shared.cancelled()  # other subscribers still await the same encoding

"""The per-client send buffer and its fair scheduler, tested directly (sans-I/O)."""

from __future__ import annotations

import asyncio

from hitrobot_server.session.outbox import QUANTUM, Outbox
from hitrobot_server.wire.frames import PendingFrames


def frames(n: int, size: int = 10) -> list[tuple[bytes, bool]]:
    return [(bytes([n]) * size, False)]


async def drain(box: Outbox, limit: int = 10_000) -> list[bytes]:
    """Everything queued, in the order the pump would write it (one payload per frame)."""
    out: list[bytes] = []
    while len(box) and len(out) < limit:
        got = await asyncio.wait_for(box.get(), 1)
        out += [data for data, _ in got]
        box.sent()
    return out


async def test_control_frames_go_first_and_are_never_dropped():
    box = Outbox(limit=25)
    box.put(frames(1), droppable=True)
    box.put(frames(2), droppable=False)  # a reply
    box.put(frames(3), droppable=True)
    for n in range(4, 10):
        box.put(frames(n), droppable=False)  # replies are not charged to the topic limit
    assert box.put(frames(10), droppable=True)  # evicts 1, the oldest topic message
    assert box.dropped == 1 and box.drops(None) == 1
    assert [d[0] for d in await drain(box)] == [2, 4, 5, 6, 7, 8, 9, 3, 10]


async def test_a_small_stream_is_not_stuck_behind_a_big_one_and_each_keeps_its_order():
    box = Outbox(limit=10_000_000)
    for i in range(3):
        box.put([(b"B%d" % i + b"." * 200_000, False)], droppable=True, key="/map")
    for i in range(10):
        box.put([(b"s%d" % i, False)], droppable=True, key="/pose")
    order = [d[:2] for d in await drain(box)]
    smalls = [i for i, d in enumerate(order) if d.startswith(b"s")]
    assert [order[i] for i in smalls] == [b"s%d" % i for i in range(10)]  # in order
    assert smalls[-1] < order.index(b"B1")  # all small ones before the 2nd big one
    assert [d for d in order if d.startswith(b"B")] == [b"B0", b"B1", b"B2"]


async def test_fragments_interleave_with_another_stream_and_a_started_group_is_never_dropped():
    box = Outbox(limit=5 * QUANTUM)
    group = [(b"F%d" % i + b"." * (QUANTUM - 2), False) for i in range(4)]
    box.put(group, droppable=True, key="/cloud")
    first = await box.get()
    box.sent()
    assert first[0][0][:2] == b"F0"
    box.put(frames(1), droppable=True, key="/pose")
    for i in range(3):  # later clouds push the queue over its limit: they, not F1..F3, go
        box.put([(b"G%d" % i + b"." * (2 * QUANTUM), False)], droppable=True, key="/cloud")
    order = [d[:2] for d in await drain(box)]
    assert order[:1] == [bytes([1]) * 2]  # the pose went before the rest of the group
    assert [d for d in order if d.startswith(b"F")] == [b"F1", b"F2", b"F3"]
    assert box.drops("/cloud") >= 1 and box.drops("/pose") == 0


async def test_thinning_hits_the_stream_over_its_share_only_and_says_so_once():
    thinned: list = []
    box = Outbox(limit=50_000)
    box.on_thinned = thinned.append
    for i in range(200):  # 10 big for every small one, far over the limit, nothing sent
        box.put([(b"b" * 5_000, False)], droppable=True, key="/map")
        if i % 10 == 0:
            box.put([(b"p%d" % i, False)], droppable=True, key="/pose")
    assert box.drops("/pose") == 0 and box.drops("/map") > 100
    assert thinned == ["/map"]
    assert box.buffered <= 50_000
    assert len([d for d in await drain(box) if d.startswith(b"p")]) == 20


async def test_depth_one_keeps_only_the_latest_value():
    box = Outbox()
    box.busy = True  # the pump is writing: everything queues
    for n in range(5):
        box.put(frames(n), droppable=True, key="/state", depth=1)
    assert box.drops("/state") == 4
    assert await drain(box) == [bytes([4]) * 10]


async def test_oversized_message_still_goes_out_when_no_topic_data_is_queued():
    box = Outbox(limit=5)
    assert box.put(frames(7, size=100), droppable=True)
    assert box.put(frames(8, size=100), droppable=True)  # the newest big one replaces it
    assert box.dropped == 1 and len(box) == 1
    assert (await box.get())[0][0] == bytes([8]) * 100


async def test_direct_write_only_when_nothing_is_queued_or_being_sent():
    box = Outbox()
    sent: list = []
    box.direct = lambda fr: sent.append(fr) or True
    assert box.put(frames(1), droppable=True, key="/a")
    assert sent == [frames(1)] and len(box) == 0
    box.busy = True
    box.put(frames(2), droppable=True, key="/a")
    assert sent == [frames(1)] and len(box) == 1


async def test_close_drains_then_ends_and_clear_frees_at_once():
    box = Outbox()
    box.put(frames(1))
    box.close()
    assert box.put(frames(2)) is False
    assert (await box.get()) == frames(1)
    assert await box.get() is None
    other = Outbox()
    other.put(frames(3), droppable=True, key="/x")
    other.put(frames(4))
    other.clear()
    assert other.buffered == 0 and len(other) == 0
    assert await other.get() is None


async def test_get_waits_for_put():
    box = Outbox()
    waiter = asyncio.ensure_future(box.get())
    await asyncio.sleep(0)
    assert not waiter.done()
    box.put(frames(5))
    assert await asyncio.wait_for(waiter, 1) == frames(5)


async def test_reply_budget_clears_room_until_the_replies_are_read_and_abort_keeps_the_last():
    box = Outbox(budget=25)
    box.put(frames(1))
    box.put(frames(2))
    assert box.room.is_set()
    box.put(frames(3))
    assert not box.room.is_set() and box.control_bytes == 30
    await box.get()
    box.sent()
    assert box.room.is_set()
    box.abort(frames(9))
    assert await drain(box) == [bytes([9]) * 10] and box.closed


async def test_a_pending_future_holds_only_its_own_stream():
    box = Outbox(limit=1000)
    sent: list = []
    box.direct = lambda fr: sent.append(fr) or True
    future = asyncio.get_running_loop().create_future()
    assert box.put(PendingFrames(future, 100), droppable=True, key="/map")
    assert box.buffered == 100
    box.put(frames(2), droppable=True, key="/map")  # behind the future, in its stream
    box.put(frames(3), droppable=True, key="/pose")  # another stream: not held
    assert sent == [] and len(box) == 3
    assert await asyncio.wait_for(box.get(), 1) == frames(3)
    box.sent()
    getter = asyncio.ensure_future(box.get())
    await asyncio.sleep(0)
    assert not getter.done()
    future.set_result(frames(1))
    assert await asyncio.wait_for(getter, 1) == frames(1)
    box.sent()
    assert await box.get() == frames(2)


async def test_a_failed_or_cancelled_future_is_skipped_and_a_cancelled_get_leaves_it_alone():
    box = Outbox()
    failed = asyncio.get_running_loop().create_future()
    failed.set_exception(RuntimeError("encoder broke"))
    box.put(PendingFrames(failed, 0), droppable=True)
    box.put(frames(3), droppable=True)
    assert await box.get() == frames(3)
    box.sent()

    shared = asyncio.get_running_loop().create_future()
    box.put(PendingFrames(shared, 0), droppable=True)
    getter = asyncio.ensure_future(box.get())
    await asyncio.sleep(0)
    getter.cancel()  # this client's pump goes away
    await asyncio.gather(getter, return_exceptions=True)
    assert not shared.cancelled()  # other subscribers still await the same encoding


async def test_forget_frees_an_unsubscribed_stream_but_finishes_a_started_group():
    box = Outbox()
    box.busy = True
    box.put([(b"f0", False), (b"f1", False)], droppable=True, key="/a")
    box.put(frames(1), droppable=True, key="/b")
    box.sent()
    assert await box.get() == [(b"f0", False)]
    box.sent()
    box.put(frames(2), droppable=True, key="/a")
    box.forget("/a")
    assert box.drops("/a") == 0
    assert sorted(await drain(box)) == sorted([b"f1", bytes([1]) * 10])
    assert box.buffered == 0

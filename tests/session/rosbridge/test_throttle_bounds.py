"""A throttled subscription cannot make the server hold an unbounded backlog: queue_length is
clamped (with a warning) and a client's throttle queues are bounded in bytes (sessions driven
sans-I/O)."""

from __future__ import annotations

from hitrobot_server.session.rosbridge.subscribe import MAX_QUEUE_LENGTH
from tests.witness import Witness

LIMIT = 200_000
BODY = "x" * 20_000


async def test_huge_queue_length_is_clamped_and_bytes_are_bounded(make_hub):
    hub = await make_hub(send_buffer_limit=LIMIT)
    witness = await Witness.on(hub.open(), hub.open())
    bad = hub.open()
    await bad.send({"op": "set_level", "level": "warning"})
    for topic in ("/big1", "/big2"):
        await bad.send({"op": "subscribe", "id": topic, "topic": topic,
                        "type": "std_msgs/String", "throttle_rate": 3_600_000,
                        "queue_length": 1_000_000})
        status = await bad.expect(op="status", id=topic)
        assert status["level"] == "warning"
        assert f"clamped to {MAX_QUEUE_LENGTH}" in status["msg"] and str(LIMIT) in status["msg"]
    pub = hub.open()
    for topic in ("/big1", "/big2"):
        await pub.send({"op": "advertise", "topic": topic, "type": "std_msgs/String"})
    for i in range(60):
        for topic in ("/big1", "/big2"):
            await pub.send({"op": "publish", "topic": topic, "msg": {"data": f"{i}{BODY}"}})
        await witness.publish(1)
    assert (await pub.call("/rosapi/get_time"))["result"] is True  # all publishes are handled
    session = next(c.session for c in hub.clients if c.session.subscriptions.subs.get("/big1"))
    ops = session.subscriptions
    queued = [len(sub._pending) for sub in ops.subs.values()]
    # 120 messages of ~20 kB were throttled; the queues keep the newest that fit in LIMIT
    assert 0 < ops.queued <= LIMIT
    assert ops.queued == sum(size for sub in ops.subs.values() for _f, size in sub._pending)
    assert sum(queued) < 120 and min(queued) >= 1
    newest = ops.subs["/big2"]._pending[-1][0]
    assert newest.msg["data"].startswith("59x")
    await witness.check()
    await bad.send({"op": "unsubscribe", "topic": "/big1"})
    await bad.send({"op": "unsubscribe", "topic": "/big2"})
    assert (await bad.call("/rosapi/get_time"))["result"] is True
    assert ops.queued == 0
    await witness.close()
    await bad.close()
    await pub.close()

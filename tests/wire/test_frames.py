"""The one frame builder: a published message's frames and a reply's come from one builder per
server, whose fragment ids never repeat; a reply built by the runner is byte for byte the
inline one, and one the runner fails to build is built inline."""

from __future__ import annotations

import orjson

from hitrobot_server.bus.core import Bus
from hitrobot_server.protocol.bulk import OFFLOAD_BYTES
from hitrobot_server.protocol.fragment import MIN_FRAGMENT_SIZE
from hitrobot_server.session.rosbridge.encodings import subscriber_frames
from hitrobot_server.session.rosbridge.frames import FrameBuilder, reply_data
from hitrobot_server.types.registry import TypeRegistry
from hitrobot_server.wire.frames import PendingFrames


def ids_of(frames) -> set[str]:
    return {orjson.loads(data)["id"] for data, _binary in frames}


def test_topic_data_and_replies_never_share_a_fragment_id():
    bus = Bus(TypeRegistry.default(), unregister_timeout=0)
    bus.advertise("/chatter", "std_msgs/String", "pub", "/n")
    builder = FrameBuilder()
    seen: list[str] = []
    for i in range(3):
        message = bus.publish("/chatter", {"data": "x" * 5000 + str(i)})
        seen += ids_of(subscriber_frames(message, "/chatter", "none", MIN_FRAGMENT_SIZE, builder))
        reply = {"op": "service_response", "values": {"message": "y" * 5000}, "result": True}
        seen += ids_of(builder.reply(reply, MIN_FRAGMENT_SIZE))
        seen += ids_of(builder.reply({**reply, "id": "c"}, MIN_FRAGMENT_SIZE))
    assert len(seen) == len(set(seen)) == 9
    assert FrameBuilder().ids.next() == "fragment:1"  # each server its own counter


async def test_a_big_reply_is_built_by_the_runner_and_equals_the_inline_one():
    reply = {"op": "service_response", "id": "c", "values": {"message": "z" * OFFLOAD_BYTES},
             "result": True}
    runs = []

    async def runner(fn, *args):
        runs.append(fn)
        return fn(*args)

    pending = FrameBuilder(runner).reply(reply, None, "png")
    assert isinstance(pending, PendingFrames)
    assert await pending.future == [(reply_data(reply, "png"), False)] and len(runs) == 1

    async def broken(fn, *args):
        raise RuntimeError("the pool broke")

    pending = FrameBuilder(broken).reply(reply, 100_000)
    frames = await pending.future  # built inline after all
    assert "".join(orjson.loads(f)["data"] for f, _ in frames).encode() == reply_data(reply)

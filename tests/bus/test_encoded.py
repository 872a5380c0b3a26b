"""A bus message's encodings (rosbridge's and Foxglove's keys of its memo), sans I/O: made once
each, ready or pending, fragments.

The worker pool is the session's (tests/session/test_offload.py runs it); here ``frames`` gets
a runner that builds the same frames on the loop once a gate opens, so the test can look at
the message while its frames are still pending.
"""

from __future__ import annotations

import asyncio

import orjson
import pytest

from hitrobot_server.bus.cdr import codec_for
from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.topics import Memo, Message
from hitrobot_server.protocol import bulk, cbor
from hitrobot_server.protocol.fragment import MIN_FRAGMENT_SIZE
from hitrobot_server.session.foxglove.subscribe import DATA
from hitrobot_server.session.rosbridge.encodings import (
    BODY,
    PUBLISH_CBOR,
    PUBLISH_JSON,
    is_binary,
    seeded,
    strongest,
    subscriber_frames,
)
from hitrobot_server.session.rosbridge.frames import FrameBuilder
from hitrobot_server.types.registry import TypeRegistry
from hitrobot_server.wire.frames import PendingFrames
from hitrobot_server.wire.memo import size_of

INLINE = FrameBuilder()  # no runner: every frame is built inline
CELLS = 600 * 600  # an OccupancyGrid this big is estimated well over bulk.OFFLOAD_BYTES


@pytest.fixture
def bus() -> Bus:
    bus = Bus(TypeRegistry.default(), unregister_timeout=0)
    bus.advertise("/chatter", "std_msgs/String", "pub", "/n")
    bus.advertise("/map", "nav_msgs/OccupancyGrid", "pub", "/n")
    return bus


def chatter(bus: Bus, text: str = "hello", seed: Memo | None = None) -> Message:
    return bus.publish("/chatter", {"data": text}, seed=seed)


def big_map(bus: Bus) -> Message:
    grid = {
        "header": {"seq": 0, "stamp": {"secs": 1, "nsecs": 2}, "frame_id": "map"},
        "info": {"map_load_time": {"secs": 0, "nsecs": 0}, "resolution": 0.05,
                 "width": 600, "height": 600,
                 "origin": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
        "data": [i % 100 for i in range(CELLS)],
    }
    return bus.publish("/map", grid)


class Gate:
    """A stand-in for the worker pool: runs the builder on the loop once opened, and counts."""

    def __init__(self) -> None:
        self.open = asyncio.Event()
        self.runs = 0

    async def __call__(self, fn, *args):
        self.runs += 1
        await self.open.wait()
        return fn(*args)


def test_each_encoding_is_made_once_and_shared(bus):
    message = chatter(bus)
    assert PUBLISH_JSON.get(message, "/chatter") is PUBLISH_JSON.get(message, "/chatter")
    assert orjson.loads(PUBLISH_JSON.get(message, "/chatter")) == {
        "op": "publish", "topic": "/chatter", "msg": {"data": "hello"}}
    body = BODY.peek(message)
    assert body == b'{"data":"hello"}'
    other = PUBLISH_JSON.get(message, "chatter")  # another spelling: its own op, the same body
    assert orjson.loads(other)["topic"] == "chatter" and BODY.peek(message) is body
    assert PUBLISH_CBOR.get(message, "/chatter") is PUBLISH_CBOR.get(message, "/chatter")
    assert cbor.decode(PUBLISH_CBOR.get(message, "/chatter"))["msg"] == {"data": "hello"}
    codec = codec_for(bus.types)
    assert message.cdr_bytes is None
    assert message.cdr(codec) is message.cdr(codec) is message.cdr_bytes
    frame = DATA.get(message, 3)
    assert DATA.get(message, 3) is frame and frame.endswith(message.cdr(codec))


def test_one_subscribers_frames_are_shared_by_every_subscriber_like_it(bus):
    enc = chatter(bus)
    frames = subscriber_frames(enc, "/chatter", "none", None, INLINE)
    assert frames == [(PUBLISH_JSON.get(enc, "/chatter"), False)]
    assert subscriber_frames(enc, "/chatter", "none", None, INLINE) is frames
    assert subscriber_frames(enc, "/chatter", "cbor", None, INLINE) == [
        (PUBLISH_CBOR.get(enc, "/chatter"), True)]
    assert subscriber_frames(enc, "/chatter", "cbor-raw", None, INLINE)[0][1] is True
    assert subscriber_frames(enc, "/chatter", "png", None, INLINE) is not frames


def test_a_seed_is_what_subscribers_get(bus):
    text = b'{"op":"publish","topic":"/chatter","msg":{"data":"as sent"}}'
    enc = chatter(bus, "as sent", seeded(len(text), "/chatter", text))
    assert subscriber_frames(enc, "/chatter", "none", None, INLINE) == [(text, False)]
    assert BODY.peek(enc) is None  # nothing was encoded again
    assert size_of(enc) == len(text)


def test_fragments_have_one_fresh_id_per_message_and_join_to_the_op(bus):
    first = chatter(bus, "x" * 5000)
    frames = subscriber_frames(first, "/chatter", "none", MIN_FRAGMENT_SIZE, INLINE)
    ops = [orjson.loads(f) for f, binary in frames if not binary]
    assert len(ops) == len(frames) > 1 and all(op["op"] == "fragment" for op in ops)
    assert all(len(op["data"]) <= MIN_FRAGMENT_SIZE for op in ops)
    assert len({op["id"] for op in ops}) == 1
    joined = "".join(op["data"] for op in sorted(ops, key=lambda o: o["num"])).encode()
    assert joined == PUBLISH_JSON.get(first, "/chatter")
    assert subscriber_frames(first, "/chatter", "none", MIN_FRAGMENT_SIZE, INLINE) is frames
    second = subscriber_frames(chatter(bus, "x" * 5000), "/chatter", "none", MIN_FRAGMENT_SIZE,
                               INLINE)
    assert orjson.loads(second[0][0])["id"] != ops[0]["id"]
    cbor_frames = subscriber_frames(first, "/chatter", "cbor", MIN_FRAGMENT_SIZE,
                                    INLINE)  # binary: never cut
    assert cbor_frames == [(PUBLISH_CBOR.get(first, "/chatter"), True)]


async def test_a_big_message_is_pending_until_its_frames_are_built(bus):
    enc = big_map(bus)
    gate = Gate()
    gated = FrameBuilder(gate)
    pending = subscriber_frames(enc, "/map", "none", None, gated)
    assert isinstance(pending, PendingFrames) and not pending.done()
    assert pending.size == size_of(enc) >= bulk.OFFLOAD_BYTES
    assert subscriber_frames(enc, "/map", "none", None, gated) is pending  # one build for all
    await asyncio.sleep(0)
    assert gate.runs == 1
    gate.open.set()
    built = await pending.future
    assert pending.ok() and pending.frames() is built
    ready = subscriber_frames(enc, "/map", "none", None, gated)
    assert ready is built and gate.runs == 1
    assert ready == [(PUBLISH_JSON.get(enc, "/map"), False)]  # the same bytes as inline


async def test_what_is_ready_is_never_pending(bus):
    gate = Gate()
    gated = FrameBuilder(gate)
    assert isinstance(subscriber_frames(chatter(bus), "/chatter", "none", None, gated), list)
    enc = big_map(bus)
    binary = subscriber_frames(enc, "/map", "cbor", None, gated)
    assert isinstance(binary, list)  # binary: always inline
    PUBLISH_JSON.get(enc, "/map")  # someone already has the JSON: fragmenting it is cheap
    assert isinstance(subscriber_frames(enc, "/map", "none", 100_000, gated), list)
    inline = subscriber_frames(enc, "/map", "none", None, INLINE)
    assert isinstance(inline, list)  # no runner: inline
    assert gate.runs == 0


async def test_a_failed_build_stays_failed_and_gives_no_frames(bus):
    enc = big_map(bus)

    async def broken(fn, *args):
        raise RuntimeError("the pool broke")

    pending = subscriber_frames(enc, "/map", "png", None, FrameBuilder(broken))
    with pytest.raises(RuntimeError):
        await pending.future
    assert pending.done() and not pending.ok() and pending.frames() is None
    assert subscriber_frames(enc, "/map", "png", None, FrameBuilder(broken)) is pending


def test_compressions():
    assert strongest(["none", "cbor", "png"]) == "cbor"
    assert strongest([]) == "none"
    assert is_binary("cbor-raw") and is_binary("cbor") and not is_binary("png")

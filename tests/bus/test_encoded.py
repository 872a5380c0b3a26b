"""A bus message's encodings, sans I/O: made once each, ready or pending, fragments.

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
from hitrobot_server.bus.topics import Message
from hitrobot_server.protocol import bulk, cbor
from hitrobot_server.protocol.fragment import MIN_FRAGMENT_SIZE
from hitrobot_server.types.registry import TypeRegistry
from hitrobot_server.wire.encoded import Encoding, Seed, encoded_of, is_binary, strongest
from hitrobot_server.wire.frames import FrameBuilder, PendingFrames

INLINE = FrameBuilder()  # no runner: every frame is built inline
CELLS = 600 * 600  # an OccupancyGrid this big is estimated well over bulk.OFFLOAD_BYTES


@pytest.fixture
def bus() -> Bus:
    bus = Bus(TypeRegistry.default(), unregister_timeout=0)
    bus.advertise("/chatter", "std_msgs/String", "pub", "/n")
    bus.advertise("/map", "nav_msgs/OccupancyGrid", "pub", "/n")
    return bus


def chatter(bus: Bus, text: str = "hello", seed: Seed | None = None) -> Message:
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
    enc = encoded_of(message)
    assert enc.publish_json("/chatter") is enc.publish_json("/chatter")
    assert orjson.loads(enc.publish_json("/chatter")) == {
        "op": "publish", "topic": "/chatter", "msg": {"data": "hello"}}
    body = enc.known(Encoding.BODY)
    assert body == b'{"data":"hello"}'
    other = enc.publish_json("chatter")  # another spelling: its own op, the same body
    assert orjson.loads(other)["topic"] == "chatter" and enc.known(Encoding.BODY) is body
    assert enc.publish_cbor("/chatter") is enc.publish_cbor("/chatter")
    assert cbor.decode(enc.publish_cbor("/chatter"))["msg"] == {"data": "hello"}
    codec = codec_for(bus.types)
    assert message.cdr_bytes is None
    assert message.cdr(codec) is message.cdr(codec) is message.cdr_bytes
    frame = enc.foxglove(3, message.cdr(codec))
    assert enc.foxglove(3, message.cdr(codec)) is frame and frame.endswith(message.cdr(codec))


def test_one_subscribers_frames_are_shared_by_every_subscriber_like_it(bus):
    enc = encoded_of(chatter(bus))
    frames = enc.frames("/chatter", "none", None, INLINE)
    assert frames == [(enc.publish_json("/chatter"), False)]
    assert enc.frames("/chatter", "none", None, INLINE) is frames
    assert enc.frames("/chatter", "cbor", None, INLINE) == [(enc.publish_cbor("/chatter"), True)]
    assert enc.frames("/chatter", "cbor-raw", None, INLINE)[0][1] is True
    assert enc.frames("/chatter", "png", None, INLINE) is not frames


def test_a_seed_is_what_subscribers_get(bus):
    text = b'{"op":"publish","topic":"/chatter","msg":{"data":"as sent"}}'
    enc = encoded_of(chatter(bus, "as sent", Seed(len(text), "/chatter", text)))
    assert enc.frames("/chatter", "none", None, INLINE) == [(text, False)]
    assert enc.known(Encoding.BODY) is None  # nothing was encoded again
    assert enc.size() == len(text)


def test_fragments_have_one_fresh_id_per_message_and_join_to_the_op(bus):
    first = encoded_of(chatter(bus, "x" * 5000))
    frames = first.frames("/chatter", "none", MIN_FRAGMENT_SIZE, INLINE)
    ops = [orjson.loads(f) for f, binary in frames if not binary]
    assert len(ops) == len(frames) > 1 and all(op["op"] == "fragment" for op in ops)
    assert all(len(op["data"]) <= MIN_FRAGMENT_SIZE for op in ops)
    assert len({op["id"] for op in ops}) == 1
    joined = "".join(op["data"] for op in sorted(ops, key=lambda o: o["num"])).encode()
    assert joined == first.publish_json("/chatter")
    assert first.frames("/chatter", "none", MIN_FRAGMENT_SIZE, INLINE) is frames
    second = encoded_of(chatter(bus, "x" * 5000)).frames("/chatter", "none", MIN_FRAGMENT_SIZE,
                                                         INLINE)
    assert orjson.loads(second[0][0])["id"] != ops[0]["id"]
    cbor_frames = first.frames("/chatter", "cbor", MIN_FRAGMENT_SIZE, INLINE)  # binary: never cut
    assert cbor_frames == [(first.publish_cbor("/chatter"), True)]


async def test_a_big_message_is_pending_until_its_frames_are_built(bus):
    enc = encoded_of(big_map(bus))
    gate = Gate()
    gated = FrameBuilder(gate)
    pending = enc.frames("/map", "none", None, gated)
    assert isinstance(pending, PendingFrames) and not pending.done()
    assert pending.size == enc.size() >= bulk.OFFLOAD_BYTES
    assert enc.frames("/map", "none", None, gated) is pending  # one build for every subscriber
    await asyncio.sleep(0)
    assert gate.runs == 1
    gate.open.set()
    built = await pending.future
    assert pending.ok() and pending.frames() is built
    ready = enc.frames("/map", "none", None, gated)
    assert ready is built and gate.runs == 1
    assert ready == [(enc.publish_json("/map"), False)]  # the same bytes as inline


async def test_what_is_ready_is_never_pending(bus):
    gate = Gate()
    gated = FrameBuilder(gate)
    assert isinstance(encoded_of(chatter(bus)).frames("/chatter", "none", None, gated), list)
    enc = encoded_of(big_map(bus))
    assert isinstance(enc.frames("/map", "cbor", None, gated), list)  # binary: always inline
    enc.publish_json("/map")  # someone already has the JSON: fragmenting it is cheap
    assert isinstance(enc.frames("/map", "none", 100_000, gated), list)
    assert isinstance(enc.frames("/map", "none", None, INLINE), list)  # no runner: inline
    assert gate.runs == 0


async def test_a_failed_build_stays_failed_and_gives_no_frames(bus):
    enc = encoded_of(big_map(bus))

    async def broken(fn, *args):
        raise RuntimeError("the pool broke")

    pending = enc.frames("/map", "png", None, FrameBuilder(broken))
    with pytest.raises(RuntimeError):
        await pending.future
    assert pending.done() and not pending.ok() and pending.frames() is None
    assert enc.frames("/map", "png", None, FrameBuilder(broken)) is pending


def test_compressions():
    assert strongest(["none", "cbor", "png"]) == "cbor"
    assert strongest([]) == "none"
    assert is_binary("cbor-raw") and is_binary("cbor") and not is_binary("png")

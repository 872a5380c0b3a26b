"""Big ops and messages off the event loop: order, latching, identical bytes, errors, liveness.

Sessions are driven directly (no sockets) where the socket adds nothing: a test feeds frames
with ``receive`` and awaits what it returns, as the WebSocket transport does, and reads the
subscriber's outbox, which awaits offloaded encodings in place like the transport's pump.
"""

from __future__ import annotations

import asyncio
import base64
import io
import os
import time

import cbor2
import numpy as np
import orjson
import pytest
from PIL import Image

from hitrobot_server.bus.core import Bus
from hitrobot_server.procmem import children
from hitrobot_server.protocol import bulk, cbor, rawmsg
from hitrobot_server.session.offload import WorkerPool
from hitrobot_server.session.options import SessionOptions
from hitrobot_server.session.rosbridge.encodings import (
    PUBLISH_JSON,
    PUBLISH_PNG,
    has_lists,
    publish_frames,
    subscriber_frames,
)
from hitrobot_server.session.rosbridge.session import Session
from hitrobot_server.session.rosbridge.verbatim import VERBATIM_MIN
from hitrobot_server.types.convert import from_json
from hitrobot_server.types.registry import TypeRegistry
from hitrobot_server.wire.frames import PendingFrames
from tests.helpers import WsClient
from tests.session.rosbridge.test_encodings import decode_png_op

BIG = 700  # a BIG x BIG OccupancyGrid is ~1.2 MB of JSON: well over bulk.OFFLOAD_BYTES


def grid(size: int, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    return {
        "header": {"seq": seed, "stamp": {"secs": 10, "nsecs": 20}, "frame_id": "map"},
        "info": {"map_load_time": {"secs": 1, "nsecs": 2}, "resolution": 0.05,
                 "width": size, "height": size,
                 "origin": {"position": {"x": 1.0, "y": 2.0, "z": 0.0},
                            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
        "data": rng.choice(np.array([-1, 0, 100], dtype=np.int8), size * size).tolist(),
    }


def publish_text(topic: str, msg: dict, **extra) -> str:
    return orjson.dumps({"op": "publish", "topic": topic, "msg": msg, **extra}).decode()


@pytest.fixture
def bus() -> Bus:
    return Bus(TypeRegistry.default(), unregister_timeout=0)


def session(bus: Bus) -> Session:
    return Session(bus, SessionOptions())


async def feed(s: Session, obj_or_text) -> None:
    """One frame in, as the transport does it: await an offloaded op before the next frame."""
    text = obj_or_text if isinstance(obj_or_text, str) else orjson.dumps(obj_or_text).decode()
    pending = s.receive(text)
    if pending is not None:
        await pending


async def next_op(s: Session, op: str, timeout: float = 60) -> dict:
    """The next op ``op`` in the session's outbox (awaiting offloaded frames in place)."""
    while True:
        frames = await asyncio.wait_for(s.outbox.get(), timeout)
        s.outbox.sent()
        data, binary = frames[0]
        assert not binary
        msg = orjson.loads(data if len(frames) == 1 else "".join(
            orjson.loads(f)["data"] for f, _ in frames))
        if msg["op"] == op:
            return msg


async def test_a_small_message_never_overtakes_an_earlier_big_one(bus):
    pub, sub = session(bus), session(bus)
    await feed(pub, {"op": "advertise", "topic": "/map", "type": "nav_msgs/OccupancyGrid"})
    await feed(sub, {"op": "subscribe", "topic": "/map"})
    big, small = grid(BIG, 1), grid(2, 2)
    assert len(publish_text("/map", big)) >= bulk.OFFLOAD_BYTES
    await feed(pub, publish_text("/map", big))
    await feed(pub, publish_text("/map", small))  # published while the big one is encoded
    first = await next_op(sub, "publish")
    second = await next_op(sub, "publish")
    assert first["msg"]["data"] == big["data"] and first["msg"]["header"]["seq"] == 1
    assert second["msg"]["data"] == small["data"]


async def test_ops_of_one_client_run_in_order_over_a_real_socket(server):
    pub = await WsClient.open(server.port)
    sub = await WsClient.open(server.port)
    await sub.send({"op": "subscribe", "id": "s", "topic": "/map",
                    "type": "nav_msgs/OccupancyGrid"})
    await sub.call("/rosapi/get_time")  # subscribed: ops of one client run in order
    big, small = grid(BIG, 1), grid(2, 2)
    await pub.send(publish_text("/map", big))  # implicit advertise: the topic exists
    await pub.send(publish_text("/map", small))  # the reader waits for the big op first
    first = await sub.expect(op="publish", timeout=60)
    second = await sub.expect(op="publish", timeout=60)
    assert first["msg"]["data"] == big["data"] and second["msg"]["data"] == small["data"]


async def test_late_joiner_gets_the_latest_latched_message_offloaded_or_not(bus):
    pub = session(bus)
    await feed(pub, {"op": "advertise", "topic": "/map", "type": "nav_msgs/OccupancyGrid",
                     "latch": True})
    big = grid(BIG, 3)
    await feed(pub, publish_text("/map", big))
    late = session(bus)
    await feed(late, {"op": "subscribe", "topic": "/map", "compression": "png"})
    got = decode_png_op(await next_op(late, "png"))
    assert got["topic"] == "/map" and got["msg"]["data"] == big["data"]

    small = grid(3, 4)
    await feed(pub, publish_text("/map", small))
    later = session(bus)
    await feed(later, {"op": "subscribe", "topic": "/map"})
    assert (await next_op(later, "publish"))["msg"]["data"] == small["data"]


def canonical_pair(type_name: str, msg: dict) -> tuple[dict, dict]:
    """The canonical message converted inline (plain lists) and as the worker hands it over
    (long lists compacted to numpy)."""
    reg = TypeRegistry.default()
    mtype = reg.msg(type_name)
    text = orjson.dumps({"op": "publish", "msg": msg})
    inline, _ = from_json(mtype, orjson.loads(text)["msg"], reg)
    compacted = bulk.decode_json(text)["msg"]
    assert any(isinstance(v, np.ndarray) for v in compacted.values())
    offloaded, _ = from_json(mtype, compacted, reg)
    return inline, offloaded


SAMPLES = {
    "nav_msgs/OccupancyGrid": grid(120, 5),
    "sensor_msgs/LaserScan": {
        "header": {"stamp": {"secs": 1, "nsecs": 2}, "frame_id": "laser"},
        "angle_min": -1.5, "angle_max": 1.5, "angle_increment": 0.001,
        "ranges": np.random.default_rng(6).uniform(0.1, 30, 6000).tolist(),
        "intensities": [float(i % 7) for i in range(5000)] + [3] * 10,  # ints in a float array
    },
    "sensor_msgs/Image": {
        "header": {"stamp": {"secs": 1, "nsecs": 2}, "frame_id": "cam"},
        "height": 40, "width": 50, "encoding": "mono8", "step": 50,
        "data": [i % 256 for i in range(2000)],  # uint8[] as a list of integers
    },
}


@pytest.mark.parametrize("type_name", sorted(SAMPLES))
def test_compacted_message_encodes_byte_for_byte_like_the_inline_one(type_name):
    reg = TypeRegistry.default()
    mtype = reg.msg(type_name)
    inline, offloaded = canonical_pair(type_name, SAMPLES[type_name])
    topic = "/t"
    json_inline = publish_frames(topic, inline, "none", None, "f:1")
    assert publish_frames(topic, offloaded, "none", None, "f:1") == json_inline
    assert publish_frames(topic, offloaded, "png", None, "f:1") == publish_frames(
        topic, inline, "png", None, "f:1")
    assert publish_frames(topic, offloaded, "none", 5000, "f:1") == publish_frames(
        topic, inline, "none", 5000, "f:1")
    assert cbor.encode_publish_cbor(topic, offloaded, mtype, reg) == cbor.encode_publish_cbor(
        topic, inline, mtype, reg)
    stamp = (5, 6)
    assert rawmsg.encode_publish_cbor_raw(
        topic, offloaded, mtype, reg, stamp
    ) == rawmsg.encode_publish_cbor_raw(topic, inline, mtype, reg, stamp)


@pytest.mark.parametrize("compression,fragment_size", [("none", None), ("png", None),
                                                       ("none", 100_000), ("png", 50_000)])
async def test_offloaded_frames_equal_the_inline_encoding(bus, compression, fragment_size):
    pub, sub = session(bus), session(bus)
    await feed(pub, {"op": "advertise", "topic": "/map", "type": "nav_msgs/OccupancyGrid"})
    captured = []
    topic = bus.topic("/map")
    topic.subscribers["spy"] = ("spy", captured.append)
    await feed(sub, {"op": "subscribe", "topic": "/map", "compression": compression,
                     "fragment_size": fragment_size})
    await feed(pub, publish_text("/map", grid(BIG, 7)))
    message = captured[0]
    offloaded = subscriber_frames(message, "/map", compression, fragment_size, sub.frames)
    frames = await offloaded.future if isinstance(offloaded, PendingFrames) else offloaded
    json_inline = PUBLISH_JSON.get(message, "/map")  # the inline builders, never offloaded
    inline = PUBLISH_PNG.get(message, "/map") if compression == "png" else json_inline
    if fragment_size:
        assert len(frames) > 1
        ops = [orjson.loads(f) for f, _ in frames]
        assert all(len(op["data"]) <= fragment_size for op in ops)
        assert "".join(op["data"] for op in sorted(ops, key=lambda o: o["num"])).encode() == inline
    else:
        assert frames == [(inline, False)]


async def test_big_malformed_ops_get_the_same_status_errors(bus):
    pub = session(bus)
    await feed(pub, {"op": "advertise", "topic": "/map", "type": "nav_msgs/OccupancyGrid"})
    text = publish_text("/map", grid(BIG, 8))
    await feed(pub, text[:-1])  # cut short
    error = await next_op(pub, "status")
    assert error["level"] == "error" and error["msg"].startswith("invalid JSON: ")

    for bad, expected in (
        (300, "field 'data[12345]' value 300 is out of range for int8 [-128, 127]"),
        ("x", "field 'data[12345]' must be an integer, got string"),
        (True, "field 'data[12345]' must be an integer, got boolean"),
    ):
        msg = grid(BIG, 9)
        msg["data"][12345] = bad
        await feed(pub, publish_text("/map", msg, id=f"bad-{bad}"))
        error = await next_op(pub, "status")
        assert error["level"] == "error" and error["id"] == f"bad-{bad}"
        assert expected in error["msg"]

    await feed(pub, {"op": "png", "id": "p1", "data": "A" * bulk.OFFLOAD_BYTES})
    error = await next_op(pub, "status")
    assert error["id"] == "p1" and "field 'data' is not a valid PNG payload" in error["msg"]

    # nothing was lost: the client, its advertisement and the bus still work
    sub = session(bus)
    await feed(sub, {"op": "subscribe", "topic": "/map"})
    await feed(pub, publish_text("/map", grid(BIG, 10)))
    assert (await next_op(sub, "publish"))["msg"]["header"]["seq"] == 10


async def test_a_big_fragmented_publish_is_decoded_off_the_loop_and_delivered(bus):
    pub, sub = session(bus), session(bus)
    await feed(pub, {"op": "advertise", "topic": "/map", "type": "nav_msgs/OccupancyGrid"})
    await feed(sub, {"op": "subscribe", "topic": "/map"})
    text = publish_text("/map", grid(BIG, 11))
    size = 200_000
    parts = [text[i : i + size] for i in range(0, len(text), size)]
    for num, part in enumerate(parts):
        await feed(pub, {"op": "fragment", "id": "up", "num": num, "total": len(parts),
                         "data": part})
    got = await next_op(sub, "publish")
    assert got["msg"]["data"] == orjson.loads(text)["msg"]["data"]


async def test_other_clients_get_answers_while_a_big_map_is_processed(server):
    pub = await WsClient.open(server.port)
    sub = await WsClient.open(server.port)
    other = await WsClient.open(server.port)
    await sub.send({"op": "subscribe", "id": "s", "topic": "/map",
                    "type": "nav_msgs/OccupancyGrid", "compression": "png"})
    await sub.call("/rosapi/get_time")  # subscribed: ops of one client run in order
    events: list[str] = []

    async def map_arrives() -> dict:
        op = await sub.expect(op="png", timeout=60)
        events.append("map")
        return op

    waiting = asyncio.create_task(map_arrives())
    await pub.send(publish_text("/map", grid(2000, 12)))
    for _ in range(3):  # round trips complete while the map is parsed, converted, encoded
        response = await other.call("/rosapi/get_time", timeout=60)
        assert response["result"] is True
        events.append("answer")
    got = decode_png_op(await waiting)
    assert got["msg"]["info"]["width"] == 2000
    assert events == ["answer", "answer", "answer", "map"]


async def test_a_canonical_publish_is_relayed_as_the_clients_own_text(bus):
    pub, sub = session(bus), session(bus)
    await feed(pub, {"op": "advertise", "topic": "/a", "type": "std_msgs/Float64MultiArray"})
    await feed(sub, {"op": "subscribe", "topic": "/a"})
    values = ",".join(f"{i}.5" for i in range(400))  # > VERBATIM_MIN: worth reusing
    body = '{"data":[' + values + '],"layout":{"dim":[],"data_offset":0}}'  # not field order
    roslibjs = f'{{"op":"publish","id":"publish:/a:1","topic":"/a","msg":{body},"latch":false}}'
    assert len(roslibjs) >= VERBATIM_MIN
    await feed(pub, roslibjs)
    frames = await sub.outbox.get()
    assert frames == [(f'{{"op":"publish","topic":"/a","msg":{body}}}'.encode(), False)]
    sub.outbox.sent()
    altered = body.replace("0.5,", "0,", 1)  # an int in a float array: re-encoded as 0.0
    await feed(pub, f'{{"op":"publish","topic":"/a","msg":{altered}}}')
    frames = await sub.outbox.get()
    sub.outbox.sent()
    out = frames[0][0]
    assert out.startswith(b'{"op":"publish","topic":"/a","msg":{"layout":')
    assert orjson.loads(out)["msg"]["data"][:2] == [0.0, 1.5] and b"[0.0,1.5," in out
    await feed(pub, '{"op":"publish","topic":"/a","msg":{"data":[1.5],"layout":{"dim":[],'
                    '"data_offset":0}}}')  # short: re-encoded, in field order
    frames = await sub.outbox.get()
    assert frames[0][0].startswith(b'{"op":"publish","topic":"/a","msg":{"layout":')


async def test_only_the_text_passed_with_the_op_is_relayed_as_it_is(bus):
    """The client's text reaches publish as handle()'s ``frame`` argument: a decoded op
    handed over without it is encoded again, the same op with it goes out as written."""
    pub, sub = session(bus), session(bus)
    await feed(pub, {"op": "advertise", "topic": "/a", "type": "std_msgs/Float64MultiArray"})
    await feed(sub, {"op": "subscribe", "topic": "/a"})
    values = ",".join(f"{i}.5" for i in range(400))
    body = '{"data":[' + values + '],"layout":{"dim":[],"data_offset":0}}'  # not field order
    text = f'{{"op":"publish","topic":"/a","msg":{body}}}'  # long enough to be worth reusing
    assert pub.handle(orjson.loads(text)) is None
    frames = await sub.outbox.get()
    sub.outbox.sent()
    assert frames[0][0].startswith(b'{"op":"publish","topic":"/a","msg":{"layout":')
    assert pub.handle(orjson.loads(text), text) is None
    frames = await sub.outbox.get()
    assert frames == [(text.encode(), False)]


async def test_a_publish_in_the_seeds_spelling_is_relayed_in_the_sdks(bus):
    """A field renamed by the alias table (seed ``line`` → SDK ``lines``) is not the client's
    text any more, however long the op: subscribers get the canonical field name."""
    pub, sub = session(bus), session(bus)
    topic = "/slamware_ros_sdk_server_node/add_lines"
    await feed(pub, {"op": "advertise", "topic": topic, "type": "slamware_ros_sdk/AddLinesRequest"})
    await feed(sub, {"op": "subscribe", "topic": topic})
    line = {"id": 1, "start": {"x": 0.5, "y": 0.5}, "end": {"x": 1.5, "y": 0.5}}
    body = {"usage": {"usage": 0}, "line": [line] * 40}
    text = publish_text(topic, body)
    assert len(text) >= VERBATIM_MIN
    await feed(pub, text)
    msg = (await next_op(sub, "publish", timeout=10))["msg"]
    assert "line" not in msg and len(msg["lines"]) == 40

def test_only_types_with_variable_arrays_can_be_big():
    reg = TypeRegistry.default()
    assert has_lists(reg.msg("nav_msgs/OccupancyGrid"), reg)
    assert has_lists(reg.msg("nav_msgs/Path"), reg)  # poses[]
    assert has_lists(reg.msg("visualization_msgs/MarkerArray"), reg)  # nested
    assert not has_lists(reg.msg("nav_msgs/Odometry"), reg)  # fixed covariance[36]
    assert not has_lists(reg.msg("std_msgs/String"), reg)


async def test_big_hostile_ops_are_checked_like_small_ones(bus):
    """The worker path applies the same value checks (lone surrogates, >64-bit integers in
    CBOR) and the png size check before decoding, and reports them against the op."""
    pub = session(bus)
    await feed(pub, {"op": "advertise", "topic": "/map", "type": "nav_msgs/OccupancyGrid"})
    text = publish_text("/map", grid(BIG, 11), id="surrogate")
    # a NaN literal sends the text to the lenient parser, which would accept the surrogate
    text = text.replace('"frame_id":"map"', '"frame_id":"bad\\ud800"')
    text = text.replace('"resolution":0.05', '"resolution":NaN')
    assert len(text) >= bulk.OFFLOAD_BYTES
    await feed(pub, text)
    error = await next_op(pub, "status")
    assert error["level"] == "error" and error["id"] == "surrogate"
    assert "ud800" not in error["msg"]  # the value itself is never echoed

    big_int = cbor2.dumps({"op": "publish", "id": "bigint", "topic": "/map",
                                "msg": {"data": [2**70] + [0] * bulk.OFFLOAD_BYTES}})
    pending = pub.receive(big_int, binary=True)
    assert pending is not None  # it went to the worker
    await pending
    error = await next_op(pub, "status")
    assert error["level"] == "error" and error["id"] == "bigint"

    side = 3000  # 27 MB of pixels declared; the data padded over the offload threshold
    bomb = io.BytesIO()
    Image.new("RGB", (side, side)).save(bomb, format="PNG")
    data = base64.b64encode(bomb.getvalue()).decode()
    data += "=" * (bulk.OFFLOAD_BYTES - len(data) + 4 - (bulk.OFFLOAD_BYTES % 4))
    small = Session(bus, SessionOptions(max_frame_size=1_000_000))
    await feed(small, {"op": "png", "id": "bomb", "data": data})
    error = await next_op(small, "status")
    assert error["id"] == "bomb" and f"{side}x{side} pixels" in error["msg"]


async def test_a_big_frame_before_auth_closes_without_parsing(bus):
    secret = "0123456789abcdef"
    s = Session(bus, SessionOptions(authenticate=True, auth_secret=secret))
    await feed(s, publish_text("/map", grid(BIG, 12), id="early"))
    error = await next_op(s, "status")
    assert error["level"] == "error" and "not authenticated" in error["msg"]
    assert s.outbox.closed


async def test_an_idle_pool_gives_its_processes_back_and_starts_again():
    """After ``idle_stop`` seconds without a task the pool's process exits (its memory given
    back); the next big op starts a new one."""
    pool = WorkerPool(workers=1, idle_stop=0.3)
    try:
        first = await pool.run(os.getpid)
        assert first in children(os.getpid())
        deadline = time.monotonic() + 20
        while first in children(os.getpid()) and time.monotonic() < deadline:
            await asyncio.sleep(0.05)  # polling the process table, bounded
        assert first not in children(os.getpid())
        second = await pool.run(os.getpid)
        assert second != first and second in children(os.getpid())
    finally:
        pool.shutdown()

"""Fragments, png and cbor on the wire, end to end."""

from __future__ import annotations

import base64
import io
import json
import math

import numpy as np
from PIL import Image


def decode_png_op(op: dict) -> dict:
    """Decode as roslibjs 2.x does: PNG pixels → UTF-8 text → JSON (trailing \\n is padding)."""
    img = Image.open(io.BytesIO(base64.b64decode(op["data"])))
    assert img.mode == "RGB"
    return json.loads(img.tobytes().decode("utf-8"))


def join_fragments(frags: list[dict]) -> dict:
    frags = sorted(frags, key=lambda f: f["num"])
    assert [f["num"] for f in frags] == list(range(frags[0]["total"]))
    assert all(isinstance(f["total"], int) and f["id"] for f in frags)
    return json.loads("".join(f["data"] for f in frags))


async def test_one_megabyte_round_trips_fragmented_both_ways(hub):
    sender = hub.open()
    receiver = hub.open()
    payload = "".join(chr(0x41 + i % 26) for i in range(1_000_000)) + "é中"
    await receiver.send({"op": "subscribe", "topic": "/big", "type": "std_msgs/String",
                         "fragment_size": 65536})
    text = json.dumps({"op": "publish", "topic": "/big", "msg": {"data": payload}})
    size = 100_000
    total = math.ceil(len(text) / size)
    order = list(range(total))[::-1]  # out of order on purpose: joined by num
    for n in order:
        await sender.send({"op": "fragment", "id": "up1", "num": n, "total": total,
                           "data": text[n * size:(n + 1) * size]})
    first = await receiver.expect(op="fragment", timeout=10)
    frags = [first] + [await receiver.expect(op="fragment", id=first["id"], timeout=10)
                       for _ in range(first["total"] - 1)]
    joined = join_fragments(frags)
    assert joined["op"] == "publish" and joined["msg"]["data"] == payload


async def test_png_4000x4000_occupancy_grid_decodes_identically(hub):
    pub = hub.open()
    sub = hub.open()
    rng = np.random.default_rng(1)
    data = rng.choice(np.array([-1, 0, 100], dtype=np.int8), size=4000 * 4000).tolist()
    grid = {"header": {"seq": 0, "stamp": {"secs": 5, "nsecs": 6}, "frame_id": "map"},
            "info": {"map_load_time": {"secs": 1, "nsecs": 2}, "resolution": 0.05,
                     "width": 4000, "height": 4000,
                     "origin": {"position": {"x": -100.0, "y": -100.0, "z": 0.0},
                                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
            "data": data}
    await pub.send({"op": "advertise", "topic": "/map", "type": "nav_msgs/OccupancyGrid",
                    "latch": True})
    await pub.send({"op": "publish", "topic": "/map", "msg": grid})
    await sub.send({"op": "subscribe", "topic": "/map", "type": "nav_msgs/OccupancyGrid",
                    "compression": "png"})
    op = await sub.expect(op="png", timeout=60)
    decoded = decode_png_op(op)
    assert decoded["op"] == "publish" and decoded["topic"] == "/map"
    assert decoded["msg"]["info"] == {**grid["info"], "resolution": decoded["msg"]["info"][
        "resolution"]}
    assert abs(decoded["msg"]["info"]["resolution"] - 0.05) < 1e-6
    assert decoded["msg"]["header"] == grid["header"]
    assert decoded["msg"]["data"] == data


async def test_png_payload_stays_ascii_for_latin1_decoders(peer):
    await peer.send({"op": "subscribe", "topic": "/s", "type": "std_msgs/String",
                       "compression": "png"})
    await peer.send({"op": "publish", "topic": "/s", "msg": {"data": "größe 😀"}})
    op = await peer.expect(op="png")
    img = Image.open(io.BytesIO(base64.b64decode(op["data"])))
    raw = img.tobytes()
    assert raw.isascii()
    assert json.loads(raw.decode("latin-1"))["msg"]["data"] == "größe 😀"


async def test_cbor_binary_frame_with_typed_arrays(peer):
    await peer.send({"op": "subscribe", "topic": "/scan", "type": "sensor_msgs/LaserScan",
                       "compression": "cbor"})
    await peer.send({"op": "publish", "topic": "/scan",
                       "msg": {"ranges": [1.5, 2.5, None], "intensities": [], "angle_max": 1.0}})
    msg = await peer.expect(op="publish")
    assert msg["_binary"] is True
    ranges = msg["msg"]["ranges"]
    # cbor2 hands unknown tags back as CBORTag: 85 = float32 little-endian typed array
    assert ranges.tag == 85
    values = np.frombuffer(ranges.value, dtype="<f4")
    assert values[0] == 1.5 and values[1] == 2.5 and np.isnan(values[2])


async def test_cbor_raw_carries_ros1_bytes(peer):
    await peer.send({"op": "subscribe", "topic": "/n", "type": "std_msgs/Int32",
                       "compression": "cbor-raw"})
    await peer.send({"op": "publish", "topic": "/n", "msg": {"data": 258}})
    msg = await peer.expect(op="publish")
    assert msg["msg"]["bytes"] == (258).to_bytes(4, "little")
    assert isinstance(msg["msg"]["secs"], int)


async def test_png_op_from_a_client_is_decoded_and_run(hub):
    from hitrobot_server.protocol import png

    sender = hub.open()
    receiver = hub.open()
    await receiver.send({"op": "subscribe", "topic": "/from_png", "type": "std_msgs/String"})
    inner = json.dumps({"op": "publish", "topic": "/from_png", "msg": {"data": "via png"}})
    await sender.send({"op": "png", "data": png.encode(inner.encode())})
    got = await receiver.expect(op="publish", topic="/from_png")
    assert got["msg"]["data"] == "via png"

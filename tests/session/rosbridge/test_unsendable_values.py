"""Values the server could not send again (lone surrogates, integers beyond 64 bits, nesting
too deep, foreign CBOR types) are refused with a status for their op, over WebSocket and TCP,
and never reach shared state: the map manager's POIs keep being served to everyone."""

from __future__ import annotations

import json
import math

import cbor2
import pytest

from tests.helpers import TcpClient, WsClient
from tests.nodes.map_manager.util import MM, poi, start
from tests.witness import Witness

pytestmark = pytest.mark.hostile

POI_T = "map_messages/PointOfInterest"
BIG = 2**70


def poisoned_poi(op_id) -> str:
    """A POI publish holding NaN, which sends the server to its lenient fallback parser."""
    bad = poi("bad\ud800", math.nan, 1.0)
    return json.dumps({"op": "publish", "id": op_id, "topic": f"{MM}/add_poi", "msg": bad})


FRAMES = [
    # (text, id the status must carry, words the status must contain)
    (poisoned_poi("p1"), "p1", "msg.name"),
    (json.dumps({"op": "publish", "id": "p2", "topic": f"{MM}/add_poi",
                 "msg": {**poi("big", math.nan, 0.0), "type": BIG}}), "p2", "msg.type"),
    (json.dumps({"op": "publish", "id": BIG, "topic": f"{MM}/add_poi",
                 "msg": poi("bigid", math.nan, 0.0)}), None, "'id'"),
    ('{"op":"publish","id":"p4","topic":"/x","msg":' + "[" * 5000 + "NaN" + "]" * 5000 + "}",
     None, "invalid JSON"),
    ('{"op":"publish","id":"p6","topic":"/x","msg":{"bad\\udc00":NaN}}', "p6", "key"),
]

CBOR_FRAMES = [
    (cbor2.dumps({"op": "publish", "id": "c1", "topic": f"{MM}/add_poi",
                  "msg": {**poi("cbig", 0.0, 0.0), "type": BIG}}), "c1", "msg.type"),
    (cbor2.dumps({"op": "publish", "id": "c2", "topic": "/x",
                  "msg": {"data": cbor2.CBORTag(999, 1)}}), "c2", "unsupported type"),
    (cbor2.dumps({"op": "publish", "id": "c3", "topic": "/x",
                  "msg": {"data": cbor2.undefined}}), "c3", "unsupported type"),
    (cbor2.dumps({"op": "publish", "id": -BIG, "topic": "/x", "msg": {}}), None, "'id'"),
]


def check_status(status: dict, op_id, needle: str) -> None:
    assert status["level"] == "error"
    assert needle in status["msg"], status
    assert status.get("id") == op_id, status
    assert str(BIG) not in status["msg"] and "\\ud800" not in status["msg"]


async def test_poisoned_values_are_refused_and_the_poi_list_survives(make_server, tmp_path):
    server, w = await start(make_server, tmp_path)
    got = await w.call(f"{MM}/get_pois")
    assert got["result"] is True
    witness = await Witness.open(server.port)
    bad = await WsClient.open(server.port)
    await bad.send({"op": "advertise", "topic": f"{MM}/add_poi", "type": POI_T})
    for text, op_id, needle in FRAMES:
        await bad.send(text)
        check_status(await bad.expect(op="status", level="error"), op_id, needle)
    for data, op_id, needle in CBOR_FRAMES:
        await bad.ws.send(data)
        check_status(await bad.expect(op="status", level="error"), op_id, needle)
    tcp = await TcpClient.open(server.tcp_port)
    await tcp.send_bytes(poisoned_poi("t1").encode())
    check_status(await tcp.expect(op="status"), "t1", "msg.name")
    await tcp.send_bytes(json.dumps({"op": "publish", "id": BIG, "topic": "/x",
                                     "msg": {"a": math.nan}}).encode())
    check_status(await tcp.expect(op="status"), None, "'id'")
    # every bad connection is still open and served
    assert (await bad.call("/rosapi/get_time"))["result"] is True
    await tcp.send({"op": "call_service", "id": "tt", "service": "/rosapi/get_time"})
    assert (await tcp.expect(op="service_response", id="tt"))["result"] is True
    # a good POI with NaN-free values still goes in, and everyone still gets the list
    await bad.send({"op": "publish", "id": "ok", "topic": f"{MM}/add_poi",
                    "msg": poi("fine", 1.0, 1.0)})
    await w.until(lambda: [p["name"] for p in w.latest(f"{MM}/pois")["pois"]] == ["fine"],
                  10, "only the good POI")
    got = await w.call(f"{MM}/get_pois")
    assert got["result"] is True
    assert [p["name"] for p in got["values"]["poi_list"]["pois"]] == ["fine"]
    await witness.check()
    await bad.close()
    await tcp.close()
    await witness.close()
    await w.close()


async def test_nan_and_infinity_still_reach_float_fields(server):
    """The fallback parser stays for what ROS floats need (roslibpy writes these literals)."""
    witness = await Witness.open(server.port)
    sub = await WsClient.open(server.port)
    await sub.send({"op": "set_level", "level": "info"})
    await sub.send({"op": "subscribe", "id": "s", "topic": "/ranges",
                    "type": "std_msgs/Float32MultiArray"})
    await sub.expect(op="status", id="s")
    pub = await WsClient.open(server.port)
    await pub.send({"op": "advertise", "topic": "/ranges", "type": "std_msgs/Float32MultiArray"})
    await pub.send('{"op":"publish","topic":"/ranges","msg":{"data":[1.5,NaN,Infinity,'
                   '-Infinity]}}')
    got = await sub.expect(op="publish", topic="/ranges")
    assert got["msg"]["data"][0] == 1.5 and got["msg"]["data"][1:] == [None, None, None]
    await witness.check()
    await witness.close()

"""Hostile parameter values over real sockets: a value too big or too deep (also when it comes
as a JSON string) is refused with a failed response naming the limit, leaves the parameter as it
was, and ``get_param('/')`` keeps working for every client; a witness loses nothing."""

from __future__ import annotations

import json

import orjson
import pytest

from hitrobot_server.bus.params import MAX_DEPTH, MAX_VALUE_BYTES
from tests.helpers import TcpClient, WsClient
from tests.witness import Witness

pytestmark = pytest.mark.hostile


def nested(depth: int) -> str:
    return "[" * depth + "]" * depth


async def set_param(client, name: str, value: str, op_id: str) -> dict:
    await client.send({"op": "call_service", "id": op_id, "service": "/rosapi/set_param",
                       "args": {"name": name, "value": value}})
    return await client.expect(op="service_response", id=op_id, timeout=10)


async def test_big_and_deep_parameter_values_are_refused(make_server):
    server = await make_server()
    witness = await Witness.open(server.port)
    bad = await WsClient.open(server.port)
    assert (await set_param(bad, "/p", '"kept"', "ok"))["result"] is True
    refusals = [
        (nested(400), "nested 401 levels"),
        (nested(1000), "nested 1001 levels"),
        ("[" + "[]," * (MAX_VALUE_BYTES // 2) + "[]]", f"limit of {MAX_VALUE_BYTES}"),
        ('{"a":' * 200 + "1" + "}" * 200, "nested"),
    ]
    for i, (value, needle) in enumerate(refusals):
        reply = await set_param(bad, "/p", value, f"r{i}")
        assert reply["result"] is False and needle in reply["values"], reply
        status = await bad.expect(op="status", id=f"r{i}")
        assert status["level"] == "error" and needle in status["msg"]
    # a deep text quoted once more is a plain string value: accepted as a string
    assert (await set_param(bad, "/s", json.dumps(nested(300)), "str"))["result"] is True
    await witness.check()
    tcp = await TcpClient.open(server.tcp_port)
    await tcp.send({"op": "call_service", "id": "t", "service": "/rosapi/set_param",
                    "args": {"name": "/deep/" + "/".join(["n"] * MAX_DEPTH), "value": "1"}})
    reply = await tcp.expect(op="service_response", id="t")
    assert reply["result"] is False and "nested" in reply["values"]
    # the parameter is unchanged and the whole tree still encodes, for everyone
    got = await witness.sub.call("/rosapi/get_param", {"name": "/p"})
    assert got["values"]["value"] == '"kept"'
    tree = orjson.loads((await witness.sub.call("/rosapi/get_param", {"name": "/"}))
                        ["values"]["value"])
    assert tree["p"] == "kept" and "deep" not in tree
    names = (await bad.call("/rosapi/get_param_names"))["values"]["names"]
    assert "/p" in names and "/s" in names
    await witness.check()
    await tcp.close()
    await bad.close()
    await witness.close()

"""Service calls between clients and to in-process providers, sessions driven sans-I/O."""

from __future__ import annotations

import pytest

from tests.sansio import SessionClient


async def test_client_provider_round_trip_with_list_and_object_args(hub):
    provider = hub.open()
    caller = hub.open()
    await provider.send({"op": "advertise_service", "service": "/add", "type": "std_srvs/SetBool"})
    await caller.send({"op": "call_service", "id": "c1", "service": "/add", "args": [True]})
    req = await provider.expect(op="call_service")
    assert req["id"] == "service_request:/add:1" and req["args"] == {"data": True}
    await provider.send({"op": "service_response", "id": req["id"], "service": "/add",
                         "values": {"success": True, "message": "ok"}, "result": True})
    reply = await caller.expect(op="service_response", id="c1")
    assert reply == {"op": "service_response", "service": "/add", "id": "c1",
                     "values": {"success": True, "message": "ok"}, "result": True}
    await caller.send({"op": "call_service", "service": "add#legacy", "args": {"data": False}})
    req = await provider.expect(op="call_service")
    assert req["id"].endswith(":2") and req["args"] == {"data": False}
    await provider.send({"op": "service_response", "id": req["id"], "service": "/add",
                         "values": {"success": False}, "result": True})
    reply = await caller.expect(op="service_response", id="legacy")
    assert reply["service"] == "add#legacy" and reply["values"]["message"] == ""


async def test_provider_result_false_without_values_fails_caller(hub):
    provider = hub.open()
    caller = hub.open()
    await provider.send({"op": "advertise_service", "service": "/f", "type": "std_srvs/Trigger"})
    await caller.send({"op": "call_service", "id": "c", "service": "/f"})
    req = await provider.expect(op="call_service")
    await provider.send({"op": "service_response", "id": req["id"], "service": "/f",
                         "result": False})
    reply = await caller.expect(op="service_response", id="c", timeout=2)
    assert reply["result"] is False and "/f" in reply["values"]


async def test_provider_disconnect_fails_pending_and_removes_service(hub):
    provider = hub.open()
    caller = hub.open()
    await provider.send({"op": "advertise_service", "service": "/gone", "type": "std_srvs/Empty"})
    await caller.send({"op": "call_service", "id": "p", "service": "/gone"})
    await provider.expect(op="call_service")
    await provider.close()
    reply = await caller.expect(op="service_response", id="p", timeout=3)
    assert reply["result"] is False and "disconnected" in reply["values"]
    services = (await caller.call("/rosapi/services"))["values"]["services"]
    assert "/gone" not in services


async def test_unknown_service_answers_and_reports(peer):
    reply = await peer.call("/does/not/exist")
    assert reply["result"] is False and "does not exist" in reply["values"]
    status = await peer.expect(op="status")
    assert "/does/not/exist" in status["msg"]


async def test_call_timeout(hub):
    provider = hub.open()
    caller = hub.open()
    await provider.send({"op": "advertise_service", "service": "/slow", "type": "std_srvs/Empty"})
    await caller.send({"op": "call_service", "id": "t", "service": "/slow", "timeout": 0.2})
    reply = await caller.expect(op="service_response", id="t", timeout=3)
    assert reply["result"] is False and "0.2" in reply["values"]


async def test_rosapi_params_and_types(peer):
    assert (await peer.call("rosapi/set_param", {"name": "/robot/speed", "value": "0.5"}))[
        "result"]
    got = await peer.call("/rosapi/get_param", {"name": "/robot/speed"})
    assert got["values"]["value"] == "0.5"
    tree = await peer.call("/rosapi/get_param", {"name": "/robot"})
    assert tree["values"]["value"] == '{"speed":0.5}'
    names = (await peer.call("/rosapi/get_param_names"))["values"]["names"]
    assert "/robot/speed" in names
    assert (await peer.call("/rosapi/has_param", {"name": "/robot/speed"}))["values"]["exists"]
    await peer.call("/rosapi/delete_param", {"name": "/robot/speed"})
    assert not (await peer.call("/rosapi/has_param", {"name": "/robot/speed"}))["values"][
        "exists"]
    details = (await peer.call("/rosapi/message_details", {"type": "geometry_msgs/PoseStamped"}))
    defs = details["values"]["typedefs"]
    assert defs[0]["type"] == "geometry_msgs/PoseStamped"
    assert defs[0]["fieldnames"] == ["header", "pose"]
    assert defs[0]["fieldarraylen"] == [-1, -1]
    t = (await peer.call("/rosapi/get_time"))["values"]["time"]
    assert set(t) == {"secs", "nsecs"}
    await peer.send({"op": "advertise", "topic": "/x", "type": "std_msgs/String"})
    topics = (await peer.call("/rosapi/topics"))["values"]
    assert "/x" in topics["topics"]
    assert topics["types"][topics["topics"].index("/x")] == "std_msgs/String"
    assert (await peer.call("/rosapi/topic_type", {"topic": "x"}))["values"]["type"] == \
        "std_msgs/String"


@pytest.mark.parametrize(("extra", "needle"), [
    ('"compression": "bogus"', "field 'compression' must be one of"),
    ('"timeout": NaN', "field 'timeout' must be a finite number"),
    ('"timeout": -1', "field 'timeout' must be a finite number"),
    ('"timeout": Infinity', "field 'timeout' must be a finite number"),
])
async def test_call_service_with_bad_compression_or_timeout_is_refused(peer, extra, needle):
    await peer.send('{"op": "call_service", "id": "bad", "service": "/rosapi/get_time", '
                      + extra + "}")
    reply = await peer.expect(op="service_response", id="bad")
    assert reply["result"] is False and needle in reply["values"]
    status = await peer.expect(op="status", id="bad")
    assert status["level"] == "error" and needle in status["msg"]
    await peer.send({"op": "call_service", "id": "zero", "service": "/rosapi/get_time",
                       "timeout": 0})
    reply = await peer.expect(op="service_response", id="zero")
    assert reply["result"] is True  # 0 still means "no timeout"


async def _provider_and_call(
    hub, service: str, type_name: str
) -> tuple[SessionClient, SessionClient, dict]:
    """A client serving ``service`` (advertise acknowledged) and a call it has received."""
    provider = hub.open()
    caller = hub.open()
    await provider.send({"op": "set_level", "level": "info"})
    await provider.send({"op": "advertise_service", "id": "adv", "service": service,
                         "type": type_name})
    await provider.expect(op="status", id="adv")
    await caller.send({"op": "call_service", "id": "c", "service": service,
                       "args": {"a": 2, "b": 3}})
    return provider, caller, await provider.expect(op="call_service")


async def test_provider_result_false_values_reach_the_caller(hub):
    """rosbridge passes a provider's values with result:false, and ignores its result (the
    caller's call succeeded: issue 49); roslibpy's AddTwoInts test relies on it."""
    provider, caller, req = await _provider_and_call(hub, "/sum", "rospy_tutorials/AddTwoInts")
    await provider.send({"op": "service_response", "id": req["id"], "service": "/sum",
                         "values": {"sum": 5}, "result": False})
    reply = await caller.expect(op="service_response", id="c")
    assert reply["result"] is True and reply["values"] == {"sum": 5}


async def test_provider_result_null_still_answers_the_caller(hub):
    """roslibpy sends result:null when a handler returns None: the caller gets a failed
    response with the reason and the provider a status error."""
    provider, caller, req = await _provider_and_call(hub, "/sum2",
                                                     "example_interfaces/AddTwoInts")
    await provider.send({"op": "service_response", "id": req["id"], "service": "/sum2",
                         "values": {"sum": 5}, "result": None})
    reply = await caller.expect(op="service_response", id="c")
    assert reply["result"] is False and "invalid response" in reply["values"]
    assert "result" in reply["values"]
    status = await provider.expect(op="status", id=req["id"])
    assert status["level"] == "error" and "result" in status["msg"]


async def test_provider_result_false_with_bad_values_answers_both(hub):
    provider, caller, req = await _provider_and_call(hub, "/sum3", "rospy_tutorials/AddTwoInts")
    await provider.send({"op": "service_response", "id": req["id"], "service": "/sum3",
                         "values": {"total": 5}, "result": False})
    reply = await caller.expect(op="service_response", id="c")
    assert reply["result"] is False and "total" in reply["values"]
    status = await provider.expect(op="status", id=req["id"])
    assert status["level"] == "error" and "total" in status["msg"]

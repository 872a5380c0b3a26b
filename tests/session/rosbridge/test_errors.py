"""Every class of bad input gets a status error with the op's id; nothing else breaks
(sessions driven sans-I/O)."""

from __future__ import annotations

import pytest

BAD = [
    ("{not json", None, "invalid JSON"),
    ('{"id": "x1"}', "x1", "op"),
    ('[1, 2]', None, "op"),
    ('{"op": "frobnicate", "id": "x2"}', "x2", "frobnicate"),
    ('{"op": "subscribe", "id": "x3"}', "x3", "topic"),
    ('{"op": "subscribe", "id": "x4", "topic": "/a", "type": "std_msgs/String",'
     ' "throttle_rate": "fast"}', "x4", "throttle_rate"),
    ('{"op": "subscribe", "id": "x5", "topic": "/nope"}', "x5", "/nope"),
    ('{"op": "advertise", "id": "x6", "topic": "/a", "type": "foo_msgs/Nothing"}', "x6",
     "foo_msgs/Nothing"),
    ('{"op": "publish", "id": "x7", "topic": "/never_advertised", "msg": {}}', "x7",
     "/never_advertised"),
    ('{"op": "subscribe", "id": "x8", "topic": "/t", "type": "std_msgs/String",'
     ' "compression": "zip"}', "x8", "compression"),
    ('{"op": "set_level", "id": "x9", "level": "loud"}', "x9", "level"),
    ('{"op": "service_response", "id": "nobody", "service": "/s", "result": true}', "nobody",
     "nobody"),
    ('{"op": "cancel_action_goal", "id": "g1", "action": "/a"}', "g1", "g1"),
    ('{"op": "fragment", "id": "f1", "data": "{", "num": 5, "total": 2}', "f1", "num"),
    ('{"op": "png", "id": "p1", "data": "not base64 png"}', "p1", "data"),
]


@pytest.mark.parametrize(("raw", "op_id", "needle"), BAD)
async def test_bad_input_gets_status_error_and_connection_survives(hub, raw, op_id, needle):
    a = hub.open()
    b = hub.open()
    await a.send(raw)
    status = await a.expect(op="status", level="error")
    assert needle in status["msg"], status
    if op_id is None:
        assert "id" not in status or status["id"] is None
    else:
        assert status["id"] == op_id
    # the connection, the bus and the other client still work
    await b.send({"op": "subscribe", "id": "s", "topic": "/ok", "type": "std_msgs/String"})
    await a.send({"op": "publish", "topic": "/ok", "msg": {"data": "alive"}})
    got = await b.expect(op="publish", topic="/ok")
    assert got["msg"] == {"data": "alive"}
    reply = await a.call("/rosapi/get_time")
    assert reply["result"] is True
    await a.close()
    await b.close()


async def test_type_conflict_names_both_types(peer):
    await peer.send({"op": "advertise", "topic": "/c", "type": "std_msgs/String"})
    await peer.send({"op": "subscribe", "id": "tc", "topic": "/c", "type": "std_msgs/Int32"})
    status = await peer.expect(op="status", id="tc")
    assert "std_msgs/String" in status["msg"] and "std_msgs/Int32" in status["msg"]


async def test_bad_message_content_names_the_field(peer):
    await peer.send({"op": "advertise", "topic": "/p", "type": "geometry_msgs/Pose"})
    await peer.send({"op": "publish", "id": "bad", "topic": "/p",
                       "msg": {"position": {"x": "one"}}})
    status = await peer.expect(op="status", id="bad")
    assert status["level"] == "error" and "position.x" in status["msg"]


async def test_glob_denied_topic_and_service(make_hub):
    hub = await make_hub(topics_glob="/allowed/*", services_glob="/svc/*")
    c = hub.open()
    await c.send({"op": "advertise", "id": "g", "topic": "/secret", "type": "std_msgs/String"})
    status = await c.expect(op="status", id="g")
    assert "--topics-glob" in status["msg"]
    await c.send({"op": "advertise", "id": "ok", "topic": "/allowed/x", "type": "std_msgs/String"})
    await c.expect_none(op="status", id="ok", timeout=0.3)
    reply = await c.call("/private/svc")
    assert reply["result"] is False and "--services-glob" in reply["values"]
    assert (await c.call("/rosapi/topics"))["result"] is True  # rosapi is always reachable
    await c.close()


async def test_set_level_none_silences_and_warning_adds_partial_message_warning(peer):
    await peer.send({"op": "advertise", "topic": "/w", "type": "geometry_msgs/Point"})
    await peer.send({"op": "set_level", "level": "warning"})
    await peer.send({"op": "publish", "id": "part", "topic": "/w", "msg": {"x": 1}})
    warn = await peer.expect(op="status", id="part")
    assert warn["level"] == "warning" and "y" in warn["msg"]
    await peer.send({"op": "set_level", "level": "none"})
    await peer.send({"op": "frobnicate", "id": "quiet"})
    await peer.expect_none(op="status", timeout=0.4)

"""The in-process bus, without any transport."""

from __future__ import annotations

import asyncio

import pytest

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.errors import ActionError, BusError, ServiceError
from hitrobot_server.bus.params import ParamStore
from hitrobot_server.bus.services import STATUS_CANCELED, STATUS_SUCCEEDED, GoalOutcome
from hitrobot_server.session.rosbridge.encodings import PUBLISH_JSON
from hitrobot_server.types.registry import TypeRegistry


@pytest.fixture
def bus() -> Bus:
    return Bus(TypeRegistry.default(), unregister_timeout=0)


def test_publish_fans_out_one_message_object_to_all(bus):
    got = []
    bus.advertise("/a", "std_msgs/String", "pub", "/n")
    for key in ("s1", "s2", "s3"):
        bus.subscribe("a", None, key, "/n", got.append)
    bus.publish("/a", {"data": "x"})
    assert len(got) == 3 and got[0] is got[1] is got[2]  # same Message: encoded once
    assert PUBLISH_JSON.get(got[0], "/a") is PUBLISH_JSON.get(got[1], "/a")


def test_latched_replay_and_type_conflict(bus):
    bus.advertise("/map", "std_msgs/String", "pub", "/n", latch=True)
    bus.publish("/map", {"data": "m"})
    got = []
    bus.subscribe("/map", "std_msgs/msg/String", "late", "/n", got.append)
    assert got[0].msg == {"data": "m"}
    with pytest.raises(BusError, match="std_msgs/String.*std_msgs/Int32"):
        bus.subscribe("/map", "std_msgs/Int32", "x", "/n", got.append)
    with pytest.raises(BusError, match="unknown"):
        bus.advertise("/z", "nope_msgs/Nothing", "pub", "/n")


def test_failing_subscriber_does_not_starve_others(bus):
    bus.advertise("/t", "std_msgs/Int32", "pub", "/n")
    got = []

    def broken(_m):
        raise RuntimeError("boom")

    bus.subscribe("/t", None, "bad", "/n", broken)
    bus.subscribe("/t", None, "good", "/n", got.append)
    bus.publish("/t", {"data": 1})
    assert len(got) == 1


def test_unused_topic_disappears(bus):
    bus.advertise("/gone", "std_msgs/Int32", "pub", "/n")
    bus.unadvertise("/gone", "pub")
    assert bus.topic("/gone") is None


async def test_unregister_timeout_keeps_topic_for_a_while():
    bus = Bus(TypeRegistry.default(), unregister_timeout=0.05)
    bus.advertise("/linger", "std_msgs/Int32", "pub", "/n")
    bus.unadvertise("/linger", "pub")
    assert bus.topic("/linger") is not None
    bus.advertise("/linger", "std_msgs/Int32", "pub2", "/n")  # re-registered in time
    await asyncio.sleep(0.1)
    assert bus.topic("/linger") is not None
    bus.unadvertise("/linger", "pub2")
    await asyncio.sleep(0.1)
    assert bus.topic("/linger") is None


async def test_services_call_timeout_and_failures(bus):
    async def ok(req):
        return {"success": req["data"], "message": "m"}

    async def slow(req):
        await asyncio.sleep(1)
        return {}

    async def broken(req):
        raise RuntimeError("bug")

    bus.advertise_service("/ok", "std_srvs/SetBool", "p", "/n", ok)
    bus.advertise_service("/slow", "std_srvs/Empty", "p", "/n", slow)
    bus.advertise_service("/broken", "std_srvs/Empty", "p", "/n", broken)
    assert (await bus.call_service("ok", {"data": True}))["success"] is True
    with pytest.raises(ServiceError, match="within 0.05"):
        await bus.call_service("/slow", {}, timeout=0.05)
    with pytest.raises(ServiceError, match="bug"):
        await bus.call_service("/broken", {})
    with pytest.raises(ServiceError, match="does not exist"):
        await bus.call_service("/none", {})
    bus.remove_owner("p")
    assert bus.service("/ok") is None


async def test_action_goal_feedback_cancel(bus):
    async def handler(handle):
        handle.feedback({"distance_to_goal": 1.0, "speed": 0.5})
        try:
            await asyncio.wait_for(handle.cancelled.wait(), 0.05)
            return GoalOutcome(STATUS_CANCELED, {}, True)
        except TimeoutError:
            return GoalOutcome(STATUS_SUCCEEDED, {}, True)

    bus.advertise_action("/follow", "nav2_msgs/FollowPath", "p", "/n", handler)
    feedback = []
    _h, task = bus.start_goal("/follow", {}, feedback.append)
    assert (await task).status == STATUS_SUCCEEDED and feedback[0]["speed"] == 0.5
    handle, task = bus.start_goal("/follow", {})
    handle.cancel()
    assert (await task).status == STATUS_CANCELED
    with pytest.raises(ActionError):
        bus.start_goal("/nothing", {})


def test_param_store_tree_semantics():
    p = ParamStore()
    p.set("/robot/speed", 0.5)
    p.set("robot/name", "r1")
    assert p.get("/robot") == {"speed": 0.5, "name": "r1"}
    assert p.names() == ["/robot/name", "/robot/speed"]
    assert p.search("speed", "/robot/sub") == "/robot/speed"
    assert p.delete("/robot/speed") and not p.has("/robot/speed")
    with pytest.raises(KeyError):
        p.get("/missing")
    with pytest.raises(ValueError):
        p.set("/", 3)


def test_subscriber_can_reject_a_message_back_to_its_publisher(bus):
    from hitrobot_server.bus.topics import RequestRejected

    bus.advertise("/cmd", "std_msgs/String", "pub", "/n")

    def picky(message):
        if message.msg["data"] == "bad":
            raise RequestRejected("field 'data' must not be 'bad'")

    later = []
    bus.subscribe("/cmd", None, "picky", "/node", picky)
    bus.subscribe("/cmd", None, "async", "/node", later.append)
    replies = []
    bus.publish("/cmd", {"data": "bad"}, reply=lambda level, text: replies.append((level, text)))
    bus.publish("/cmd", {"data": "good"}, reply=lambda level, text: replies.append((level, text)))
    later[1].reply.fail("found out later")  # e.g. after awaiting the robot
    assert replies == [("error", "field 'data' must not be 'bad'"), ("error", "found out later")]


async def test_node_services_cannot_be_taken_over_and_client_providers_stack(bus):
    async def answer(tag):
        async def handler(request):
            return {"message": tag, "success": True}
        return handler

    bus.advertise_service("/node_svc", "std_srvs/Trigger", "node", "/node", await answer("n"))
    with pytest.raises(BusError, match=r"provided by the server \(/node\)"):
        bus.advertise_service("/node_svc", "std_srvs/Trigger", "c1", "/c1", await answer("c1"),
                              client=True)
    bus.advertise_action("/node_act", "nav2_msgs/FollowPath", "node", "/node", None)
    with pytest.raises(BusError, match="cannot be advertised by a client"):
        bus.advertise_action("/node_act", "nav2_msgs/FollowPath", "c1", "/c1", None,
                             client=True)
    assert bus.action("/node_act").owner == "node"
    assert (await bus.call_service("/node_svc", {}))["message"] == "n"
    for tag in ("c1", "c2", "c3"):
        bus.advertise_service("/shared", "std_srvs/Trigger", tag, f"/{tag}", await answer(tag),
                              client=True)
    assert (await bus.call_service("/shared", {}))["message"] == "c3"
    assert bus.unadvertise_service("/shared", "c2")  # a waiting provider leaves quietly
    assert (await bus.call_service("/shared", {}))["message"] == "c3"
    bus.remove_owner("c3")
    assert (await bus.call_service("/shared", {}))["message"] == "c1"
    assert not bus.unadvertise_service("/shared", "c2")
    assert bus.unadvertise_service("/shared", "c1")
    assert bus.service("/shared") is None and bus._services._replaced == {}

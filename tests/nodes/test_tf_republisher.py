"""tf2_web_republisher over the wire: actionlib topics, the ROS 2 action and /republish_tfs."""

from __future__ import annotations

import asyncio
import math

import pytest

from tests.helpers import WsClient

FEEDBACK = "/tf2_web_republisher/feedback"
GOAL_TYPE = "tf2_web_republisher/TFSubscriptionActionGoal"


def tf(x: float, parent: str = "map", child: str = "base_link", yaw: float = 0.0) -> dict:
    return {"transforms": [{
        "header": {"frame_id": parent, "stamp": {"secs": 1_800_000_000, "nsecs": 500_000_000}},
        "child_frame_id": child,
        "transform": {"translation": {"x": x, "y": 0.0, "z": 0.0},
                      "rotation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2),
                                   "w": math.cos(yaw / 2)}}}]}


def goal(**overrides) -> dict:
    return {"source_frames": ["/base_link"], "target_frame": "map", "angular_thres": 0.1,
            "trans_thres": 0.1, "rate": 50.0, **overrides}


@pytest.fixture
async def client(make_server):
    server = await make_server()
    c = await WsClient.open(server.port)
    await c.send({"op": "advertise", "topic": "/tf", "type": "tf2_msgs/TFMessage"})
    await c.send({"op": "publish", "topic": "/tf", "msg": tf(1.0)})
    yield c
    await c.close()


def x_of(transforms: list[dict]) -> float:
    return transforms[0]["transform"]["translation"]["x"]


async def test_actionlib_goal_streams_changes_past_the_threshold_until_cancelled(client):
    await client.send({"op": "subscribe", "topic": FEEDBACK})
    await client.send({"op": "subscribe", "topic": "/tf2_web_republisher/result"})
    await client.send({"op": "subscribe", "topic": "/tf2_web_republisher/status"})
    await client.send({"op": "advertise", "topic": "/tf2_web_republisher/goal",
                       "type": GOAL_TYPE})
    await client.send({"op": "publish", "topic": "/tf2_web_republisher/goal",
                       "msg": {"goal_id": {"id": "g1"}, "goal": goal()}})
    first = await client.expect(op="publish", topic=FEEDBACK)
    fb = first["msg"]
    assert fb["status"]["goal_id"]["id"] == "g1" and fb["status"]["status"] == 1
    stamped = fb["feedback"]["transforms"][0]
    assert stamped["header"]["frame_id"] == "map" and stamped["child_frame_id"] == "base_link"
    assert stamped["header"]["stamp"] == {"secs": 1_800_000_000, "nsecs": 500_000_000}
    assert x_of(fb["feedback"]["transforms"]) == pytest.approx(1.0)
    await client.send({"op": "publish", "topic": "/tf", "msg": tf(1.05)})  # under 0.1 m
    await client.send({"op": "publish", "topic": "/tf", "msg": tf(1.05, yaw=0.5)})  # turned
    turned = await client.expect(op="publish", topic=FEEDBACK)
    transform = turned["msg"]["feedback"]["transforms"][0]["transform"]
    assert transform["rotation"]["z"] == pytest.approx(math.sin(0.25))
    await client.send({"op": "publish", "topic": "/tf", "msg": tf(1.5, yaw=0.5)})
    moved = await client.expect(op="publish", topic=FEEDBACK)
    assert x_of(moved["msg"]["feedback"]["transforms"]) == pytest.approx(1.5)
    await client.send({"op": "advertise", "topic": "/tf2_web_republisher/cancel",
                       "type": "actionlib_msgs/GoalID"})
    await client.send({"op": "publish", "topic": "/tf2_web_republisher/cancel",
                       "msg": {"id": "g1"}})
    result = await client.expect(op="publish", topic="/tf2_web_republisher/result")
    assert result["msg"]["status"]["goal_id"]["id"] == "g1"
    assert result["msg"]["status"]["status"] == 2  # PREEMPTED
    status = await client.expect(lambda m: not m["msg"]["status_list"], op="publish",
                                 topic="/tf2_web_republisher/status")
    assert status["msg"]["status_list"] == []


async def test_invalid_goal_is_rejected_to_its_sender(client):
    await client.send({"op": "subscribe", "topic": "/tf2_web_republisher/result"})
    await client.send({"op": "advertise", "topic": "/tf2_web_republisher/goal",
                       "type": GOAL_TYPE})
    await client.send({"op": "publish", "id": "bad", "topic": "/tf2_web_republisher/goal",
                       "msg": {"goal_id": {"id": "g2"}, "goal": goal(rate=0.0)}})
    result = await client.expect(op="publish", topic="/tf2_web_republisher/result")
    assert result["msg"]["status"]["status"] == 5 and "rate" in result["msg"]["status"]["text"]
    status = await client.expect(op="status", id="bad")
    assert status["level"] == "error" and "rate" in status["msg"]


async def test_ros2_action_goal_gets_feedback_and_ends_on_cancel(client):
    await client.send({"op": "send_action_goal", "id": "a1", "action": "/tf2_web_republisher",
                       "action_type": "tf2_web_republisher_interfaces/TFSubscription",
                       "args": goal(source_frames=["base_link", "laser"]), "feedback": True})
    fb = await client.expect(op="action_feedback", id="a1")
    assert [t["child_frame_id"] for t in fb["values"]["transforms"]] == ["base_link"]
    # a frame that appears later is sent as soon as it is connected to the target
    await client.send({"op": "publish", "topic": "/tf",
                       "msg": tf(0.2, parent="base_link", child="laser")})
    fb = await client.expect(op="action_feedback", id="a1")
    assert fb["values"]["transforms"][0]["child_frame_id"] == "laser"
    assert x_of(fb["values"]["transforms"]) == pytest.approx(1.2)
    await client.send({"op": "cancel_action_goal", "id": "a1",
                       "action": "/tf2_web_republisher"})
    result = await client.expect(op="action_result", id="a1")
    assert result["status"] == 5  # CANCELED


async def test_republish_tfs_topic_and_its_timeout(client):
    reply = await client.call("/republish_tfs", {**goal(), "timeout": {"secs": 1, "nsecs": 0}})
    assert reply["result"] is True
    name = reply["values"]["topic_name"]
    assert name.startswith("/tf_repub_")
    await client.send({"op": "subscribe", "topic": name, "type": "tf2_web_republisher/TFArray"})
    msg = await client.expect(op="publish", topic=name)
    assert x_of(msg["msg"]["transforms"]) == pytest.approx(1.0)
    await client.send({"op": "unsubscribe", "topic": name})
    for _ in range(100):  # unused for longer than the timeout: the topic goes away (≤ 5 s)
        topics = (await client.call("/rosapi/topics"))["values"]["topics"]
        if name not in topics:
            break
        await asyncio.sleep(0.05)
    else:
        raise AssertionError(f"{name} still exists")
    bad = await client.call("/republish_tfs", {**goal(target_frame=""), "timeout": {}})
    assert bad["result"] is False and "target_frame" in bad["values"]


async def test_goal_of_a_client_that_left_without_cancelling_ends(client):
    """A reloaded page never cancels its TFClient goal; the goal must not run forever."""
    await client.send({"op": "subscribe", "topic": "/tf2_web_republisher/result"})
    await client.call("/rosapi/get_time")  # the subscription is in place
    leaving = await WsClient.open(int(client.ws.remote_address[1]))
    await leaving.send({"op": "advertise", "topic": "/tf2_web_republisher/goal",
                        "type": GOAL_TYPE})
    await leaving.send({"op": "publish", "topic": "/tf2_web_republisher/goal",
                        "msg": {"goal_id": {"id": "left"}, "goal": goal()}})
    await leaving.call("/rosapi/get_time")  # the goal was taken
    await leaving.close()
    result = await client.expect(op="publish", topic="/tf2_web_republisher/result")
    assert result["msg"]["status"]["goal_id"]["id"] == "left"
    assert result["msg"]["status"]["status"] == 2 and "gone" in result["msg"]["status"]["text"]

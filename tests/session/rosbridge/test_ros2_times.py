"""Times in the client's generation (issue 49): a type only ROS 2 has goes out with
``{sec, nanosec}`` (action_msgs' status, ``_action/*`` services, nav2's feedback and
results), a ROS 1 type keeps ``{secs, nsecs}``; on a real server over loopback WebSockets."""

from __future__ import annotations

import pytest

from tests.helpers import WsClient


@pytest.fixture
async def client(make_server, tmp_path):
    server = await make_server(robot="sim", demo_services=True, map_dir=str(tmp_path / "maps"))
    c = await WsClient.open(server.port)
    yield c
    await c.close()


def ros2_stamp(stamp: dict) -> bool:
    return set(stamp) == {"sec", "nanosec"} and stamp["sec"] > 1.6e9


async def test_action_status_and_cancel_service_carry_sec_nanosec(client):
    await client.send({"op": "subscribe", "topic": "/fibonacci/_action/status"})
    await client.send({"op": "send_action_goal", "id": "g1", "action": "/fibonacci",
                       "action_type": "example_interfaces/action/Fibonacci",
                       "args": {"order": 40}, "feedback": True})
    status = await client.expect(
        lambda m: m["msg"]["status_list"], op="publish", topic="/fibonacci/_action/status")
    assert ros2_stamp(status["msg"]["status_list"][0]["goal_info"]["stamp"])
    reply = await client.call("/fibonacci/_action/cancel_goal", {"goal_info": {}})
    assert reply["result"] is True
    cancelling = reply["values"]["goals_canceling"]
    assert cancelling and all(ros2_stamp(g["stamp"]) for g in cancelling)
    await client.expect(op="action_result", id="g1")


async def test_ros1_types_keep_secs_nsecs(client):
    reply = await client.call("/rosapi/get_time")
    assert set(reply["values"]["time"]) == {"secs", "nsecs"}
    await client.send({"op": "subscribe", "topic": "/odom"})
    odom = await client.expect(op="publish", topic="/odom")
    assert set(odom["msg"]["header"]["stamp"]) == {"secs", "nsecs"}


async def test_a_ros2_client_may_send_either_spelling(client):
    """What comes in is read in both spellings; what goes out on a ROS 2 topic is ROS 2's."""
    await client.send({"op": "advertise", "topic": "/t49/status",
                       "type": "action_msgs/GoalStatusArray"})
    await client.send({"op": "subscribe", "topic": "/t49/status"})
    await client.call("/rosapi/get_time")  # a round trip: both are in place
    for stamp in ({"secs": 1_700_000_000, "nsecs": 5}, {"sec": 1_700_000_000, "nanosec": 5}):
        await client.send({"op": "publish", "topic": "/t49/status", "msg": {"status_list": [
            {"goal_info": {"goal_id": {"uuid": [0] * 16}, "stamp": stamp}, "status": 2}]}})
        got = await client.expect(op="publish", topic="/t49/status")
        assert got["msg"]["status_list"][0]["goal_info"]["stamp"] == {
            "sec": 1_700_000_000, "nanosec": 5}

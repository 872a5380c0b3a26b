"""ROS 2 action ops relayed between a goal sender and a client action server (sessions
driven sans-I/O)."""

from __future__ import annotations


async def test_goal_feedback_result_and_cancel_relay(hub):
    provider = hub.open()
    caller = hub.open()
    await provider.send({"op": "advertise_action", "action": "/fib",
                         "type": "nav2_msgs/action/FollowPath"})
    await caller.send({"op": "send_action_goal", "id": "g1", "action": "/fib",
                       "action_type": "nav2_msgs/action/FollowPath",
                       "args": {"controller_id": "c"}, "feedback": True})
    goal = await provider.expect(op="send_action_goal")
    assert goal["id"] == "action_goal:/fib:1" and goal["args"]["controller_id"] == "c"
    await provider.send({"op": "action_feedback", "id": goal["id"], "action": "/fib",
                         "values": {"distance_to_goal": 2.5, "speed": 0.3}})
    fb = await caller.expect(op="action_feedback", id="g1")
    assert fb["values"]["distance_to_goal"] == 2.5
    await provider.send({"op": "action_result", "id": goal["id"], "action": "/fib",
                         "values": {}, "status": 4, "result": True})
    res = await caller.expect(op="action_result", id="g1")
    assert res["status"] == 4 and res["result"] is True

    await caller.send({"op": "send_action_goal", "id": "g2", "action": "/fib",
                       "action_type": "nav2_msgs/FollowPath", "args": {}})
    goal2 = await provider.expect(op="send_action_goal")
    await caller.send({"op": "cancel_action_goal", "id": "g2", "action": "/fib"})
    cancel = await provider.expect(op="cancel_action_goal")
    assert cancel["id"] == goal2["id"]
    await provider.send({"op": "action_result", "id": goal2["id"], "action": "/fib",
                         "status": 5, "result": False})
    res = await caller.expect(op="action_result", id="g2")
    assert res["status"] == 5 and res["result"] is False


async def test_provider_disconnect_aborts_goal(hub):
    provider = hub.open()
    caller = hub.open()
    await provider.send({"op": "advertise_action", "action": "/nav",
                         "type": "nav2_msgs/NavigateToPose"})
    await caller.send({"op": "send_action_goal", "id": "g", "action": "/nav",
                       "action_type": "nav2_msgs/NavigateToPose", "args": {}})
    await provider.expect(op="send_action_goal")
    await provider.close()
    res = await caller.expect(op="action_result", id="g", timeout=3)
    assert res["status"] == 6 and res["result"] is False


async def test_unknown_action_fails_with_status(client):
    await client.send({"op": "send_action_goal", "id": "u", "action": "/none",
                       "action_type": "nav2_msgs/NavigateToPose", "args": {}})
    res = await client.expect(op="action_result", id="u")
    assert res["result"] is False and "/none" in res["values"]

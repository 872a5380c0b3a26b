"""``/move_base`` through the ``send_action_goal`` op (issue 49), over the one goal table of
its actionlib side: a goal sent one way is listed and cancelled the other way. A real server
with the simulated robot, raw WebSocket clients on loopback."""

from __future__ import annotations

import pytest

from tests.helpers import WsClient

FAR = (20.0, 8.2)  # the far end of the corridor: a long drive


def pose(x: float, y: float) -> dict:
    return {"header": {"frame_id": "map"}, "pose": {"position": {"x": x, "y": y, "z": 0.0},
                                                    "orientation": {"w": 1.0}}}


@pytest.fixture
async def client(make_server, tmp_path):
    server = await make_server(robot="sim", map_dir=str(tmp_path / "maps"))
    c = await WsClient.open(server.port)
    await c.send({"op": "subscribe", "topic": "/odom"})
    await c.expect(op="publish", topic="/odom")  # the robot is up
    await c.send({"op": "unsubscribe", "topic": "/odom"})
    yield c
    await c.close()


def listed(ids: set[str], status: int):
    def check(m: dict) -> bool:
        return any(s["goal_id"]["id"] in ids and s["status"] == status
                   for s in m["msg"]["status_list"])
    return check


async def test_move_base_is_an_action_rosapi_lists(client):
    servers = (await client.call("/rosapi/action_servers"))["values"]["action_servers"]
    assert "/move_base" in servers


async def test_an_op_goal_shows_and_cancels_on_the_actionlib_side(client):
    await client.send({"op": "subscribe", "topic": "/move_base/status"})
    await client.send({"op": "send_action_goal", "id": "op1", "action": "/move_base",
                       "action_type": "move_base_msgs/MoveBase",
                       "args": {"target_pose": pose(*FAR)}, "feedback": True})
    active = await client.expect(lambda m: any(s["status"] == 1 for s in m["msg"]["status_list"]),
                                 op="publish", topic="/move_base/status")
    goal_id = next(s["goal_id"]["id"] for s in active["msg"]["status_list"] if s["status"] == 1)
    feedback = await client.expect(op="action_feedback", id="op1")
    assert "base_position" in feedback["values"]
    await client.send({"op": "publish", "topic": "/move_base/cancel",
                       "msg": {"id": goal_id, "stamp": {"secs": 0, "nsecs": 0}}})
    result = await client.expect(op="action_result", id="op1", timeout=10)
    assert result["status"] == 5 and result["result"] is False  # CANCELED
    await client.expect(listed({goal_id}, 2), op="publish", topic="/move_base/status")


async def test_an_actionlib_goal_shows_and_cancels_on_the_ros2_side(client):
    await client.send({"op": "subscribe", "topic": "/move_base/_action/status"})
    await client.send({"op": "subscribe", "topic": "/move_base/result"})
    await client.send({"op": "publish", "topic": "/move_base/goal", "msg": {
        "goal_id": {"id": "lib1"}, "goal": {"target_pose": pose(*FAR)}}})
    await client.expect(lambda m: any(s["status"] == 2 for s in m["msg"]["status_list"]),
                        op="publish", topic="/move_base/_action/status")  # EXECUTING
    reply = await client.call("/move_base/_action/cancel_goal", {"goal_info": {}})
    assert reply["result"] is True and len(reply["values"]["goals_canceling"]) == 1
    result = await client.expect(lambda m: m["msg"]["status"]["goal_id"]["id"] == "lib1",
                                 op="publish", topic="/move_base/result", timeout=10)
    assert result["msg"]["status"]["status"] == 2  # PREEMPTED


async def test_a_refused_op_goal_fails_with_the_reason(client):
    await client.send({"op": "send_action_goal", "id": "bad", "action": "/move_base",
                       "action_type": "move_base_msgs/MoveBase",
                       "args": {"target_pose": {**pose(*FAR), "header": {"frame_id": "odom"}}}})
    result = await client.expect(op="action_result", id="bad")
    assert result["result"] is False and "not the map frame" in result["values"]


async def test_every_listed_action_is_reached_by_the_op(client):
    """Each action rosapi lists (actionlib namespaces included) is one ``send_action_goal``
    reaches: a goal of a wrong type is refused for its type, never as unknown."""
    servers = (await client.call("/rosapi/action_servers"))["values"]["action_servers"]
    for i, name in enumerate(servers):
        await client.send({"op": "send_action_goal", "id": f"x{i}", "action": name,
                           "action_type": "std_msgs/NoSuchAction", "args": {}})
        result = await client.expect(op="action_result", id=f"x{i}")
        assert result["result"] is False and "does not exist" not in result["values"], name

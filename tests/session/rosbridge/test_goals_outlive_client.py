"""Goals outlive their client (issue 49), as rosbridge's: a goal keeps running when the
connection that sent it closes, any connection cancels it by its id, and a client opts in to
cancel-on-disconnect per goal. Two real WebSocket clients against a real server whose
``/move_base`` drives the simulated robot down a long corridor."""

from __future__ import annotations

import pytest

from tests.helpers import WsClient, until

FAR = (20.0, 8.2)  # the far end of the corridor: a drive far longer than these tests


def goal(op_id: str, **extra) -> dict:
    return {"op": "send_action_goal", "id": op_id, "action": "/move_base",
            "action_type": "move_base_msgs/MoveBase", "args": {"target_pose": {
                "header": {"frame_id": "map"},
                "pose": {"position": {"x": FAR[0], "y": FAR[1]}, "orientation": {"w": 1.0}}}},
            **extra}


@pytest.fixture
async def pair(make_server, tmp_path):
    server = await make_server(robot="sim", map_dir=str(tmp_path / "maps"))
    a, b = await WsClient.open(server.port), await WsClient.open(server.port)
    await b.send({"op": "subscribe", "topic": "/odom"})
    await b.expect(op="publish", topic="/odom")  # the robot is up
    await b.send({"op": "unsubscribe", "topic": "/odom"})
    await b.send({"op": "subscribe", "topic": "/move_base/status"})
    yield server, a, b
    await a.close()
    await b.close()


async def status_of(b: WsClient, predicate) -> dict:
    """The next ``/move_base/status`` with a goal ``predicate`` holds for: that goal's status."""
    msg = await b.expect(lambda m: any(predicate(s) for s in m["msg"]["status_list"]),
                         op="publish", topic="/move_base/status", timeout=10)
    return next(s for s in msg["msg"]["status_list"] if predicate(s))


async def a_leaves(server, a: WsClient) -> None:
    await a.close()
    await until(lambda: len(server.sessions) == 1, "the first client's session closed", 5)


async def test_a_goal_keeps_running_after_its_sender_leaves(pair):
    server, a, b = pair
    await a.send(goal("drive"))
    gid = (await status_of(b, lambda s: s["status"] == 1))["goal_id"]["id"]
    await a_leaves(server, a)
    await b.expect(op="publish", topic="/move_base/status")  # one period after it left
    after = await status_of(b, lambda s: s["goal_id"]["id"] == gid)
    assert after["status"] == 1  # ACTIVE: still driving
    # another connection cancels it by the id its sender gave it
    await b.send({"op": "cancel_action_goal", "id": "drive", "action": "/move_base"})
    ended = await status_of(b, lambda s: s["goal_id"]["id"] == gid and s["status"] == 2)
    assert ended["text"]  # PREEMPTED, with the cancel's text


async def test_cancel_on_disconnect_is_an_opt_in_per_goal(pair):
    server, a, b = pair
    await a.send(goal("mine", cancel_on_disconnect=True))
    gid = (await status_of(b, lambda s: s["status"] == 1))["goal_id"]["id"]
    await a_leaves(server, a)
    ended = await status_of(b, lambda s: s["goal_id"]["id"] == gid and s["status"] == 2)
    assert ended["text"]  # PREEMPTED, with the cancel's text


async def test_cancelling_an_unknown_id_is_still_an_error(pair):
    _server, _a, b = pair
    await b.send({"op": "cancel_action_goal", "id": "nobody", "action": "/move_base"})
    err = await b.expect(op="status", id="nobody")
    assert err["level"] == "error" and "no running goal" in err["msg"]

"""rosbridge 2.x's rosapi services (issue 49): ``interfaces``, ``action_goal_details``,
``action_result_details``, ``action_feedback_details`` and ``get_ros_version``, with its shapes,
on a real server over loopback WebSockets."""

from __future__ import annotations

import pytest

from tests.helpers import WsClient


@pytest.fixture
async def client(make_server, tmp_path):
    server = await make_server(robot="sim", demo_services=True, map_dir=str(tmp_path / "maps"))
    c = await WsClient.open(server.port)
    yield c
    await c.close()


async def values(client: WsClient, service: str, args: dict | None = None) -> dict:
    reply = await client.call(service, args or {})
    assert reply["result"] is True, f"{service}: {reply['values']}"
    return reply["values"]


async def test_interfaces_lists_messages_services_and_actions(client):
    found = (await values(client, "/rosapi/interfaces"))["interfaces"]
    assert found == sorted(found)
    for name in ("std_msgs/msg/String", "std_srvs/srv/Trigger",
                 "example_interfaces/action/Fibonacci", "nav2_msgs/action/NavigateToPose",
                 "rcl_interfaces/srv/ListParameters"):
        assert name in found
    assert not [n for n in found if n.endswith(("_Goal", "_SendGoal", "_FeedbackMessage"))]


@pytest.mark.parametrize(("service", "fields"), [
    ("action_goal_details", ["order"]),
    ("action_result_details", ["sequence"]),
    ("action_feedback_details", ["sequence"]),
])
async def test_action_part_details(client, service, fields):
    for spelling in ("example_interfaces/action/Fibonacci", "example_interfaces/Fibonacci"):
        typedefs = (await values(client, f"/rosapi/{service}", {"type": spelling}))["typedefs"]
        assert typedefs[0]["fieldnames"] == fields
        assert set(typedefs[0]) == {"type", "fieldnames", "fieldtypes", "fieldarraylen",
                                    "examples", "constnames", "constvalues"}


async def test_nested_types_are_described_and_unknown_ones_refused(client):
    typedefs = (await values(client, "/rosapi/action_feedback_details",
                             {"type": "nav2_msgs/action/NavigateToPose"}))["typedefs"]
    assert "geometry_msgs/PoseStamped" in [t["type"] for t in typedefs]
    reply = await client.call("/rosapi/action_goal_details", {"type": "no_pkg/action/Nope"})
    assert reply["result"] is False and "Nope" in str(reply["values"])


async def test_get_ros_version_agrees_with_rosdistro(client):
    assert await values(client, "/rosapi/get_ros_version") == {"version": 1, "distro": "noetic"}

"""Parameters as both ROS generations read them (issue 49): the ``/rosdistro`` and
``/rosversion`` a roscore sets, and each parameter-owning node's ``rcl_interfaces`` services
over the same store, on a real server over loopback WebSockets."""

from __future__ import annotations

import json

import pytest

from hitrobot_server.config import RobotEntry
from tests.helpers import WsClient

SLAMWARE = "/slamware_ros_sdk_server_node"


@pytest.fixture
async def client(make_server, tmp_path):
    server = await make_server(robot="sim", map_dir=str(tmp_path / "maps"))
    c = await WsClient.open(server.port)
    yield c
    await c.close()


async def ok(client: WsClient, service: str, args: dict | None = None) -> dict:
    reply = await client.call(service, args or {})
    assert reply["result"] is True, f"{service}: {reply['values']}"
    return reply["values"]


async def test_rosdistro_and_rosversion_are_set_as_roscore_sets_them(client):
    assert await ok(client, "/rosapi/get_param", {"name": "/rosdistro"}) == {
        "value": '"noetic\\n"'}
    assert await ok(client, "/rosapi/get_param", {"name": "/rosversion"}) == {
        "value": '"1.16.0\\n"'}


async def test_node_parameters_through_rcl_interfaces(client):
    services = (await ok(client, "/rosapi/services"))["services"]
    for name in ("list_parameters", "get_parameters", "set_parameters", "describe_parameters"):
        assert f"{SLAMWARE}/{name}" in services
    kind = await ok(client, "/rosapi/service_type", {"service": f"{SLAMWARE}/list_parameters"})
    assert kind == {"type": "rcl_interfaces/ListParameters"}
    names = (await ok(client, "/rosapi/get_param_names"))["names"]
    ours = sorted(n[len(SLAMWARE) + 1:].replace("/", ".") for n in names
                  if n.startswith(SLAMWARE + "/"))
    listed = (await ok(client, f"{SLAMWARE}/list_parameters", {"prefixes": [], "depth": 0}))
    assert sorted(listed["result"]["names"]) == ours
    # a value read both ways is the same
    first = ours[0]
    rosapi = await ok(client, "/rosapi/get_param", {"name": f"{SLAMWARE}/{first}"})
    values = (await ok(client, f"{SLAMWARE}/get_parameters",
                       {"names": [first, "no_such_param"]}))["values"]
    assert values[1]["type"] == 0
    field = {1: "bool_value", 2: "integer_value", 3: "double_value", 4: "string_value"}
    assert values[0][field[values[0]["type"]]] == json.loads(rosapi["value"])


async def test_set_and_describe_through_rcl_interfaces(client):
    svc = f"{SLAMWARE}/set_parameters"
    results = (await ok(client, svc, {"parameters": [
        {"name": "extra.speed", "value": {"type": 3, "double_value": 0.5}},
        {"name": "extra.tags", "value": {"type": 9, "string_array_value": ["a", "b"]}},
        {"name": "bad name!", "value": {"type": 2, "integer_value": 1}},
    ]}))["results"]
    assert [r["successful"] for r in results] == [True, True, False]
    assert "not a ROS 2 name" in results[2]["reason"]
    assert await ok(client, "/rosapi/get_param", {"name": f"{SLAMWARE}/extra/speed"}) == {
        "value": "0.5"}
    listed = await ok(client, f"{SLAMWARE}/list_parameters", {"prefixes": ["extra"], "depth": 0})
    assert listed["result"] == {"names": ["extra.speed", "extra.tags"], "prefixes": ["extra"]}
    described = (await ok(client, f"{SLAMWARE}/describe_parameters",
                          {"names": ["extra.tags", "gone"]}))["descriptors"]
    assert [(d["name"], d["type"]) for d in described] == [("extra.tags", 9), ("gone", 0)]
    # NOT_SET undeclares it, as in ROS 2
    await ok(client, svc, {"parameters": [{"name": "extra.speed", "value": {"type": 0}}]})
    assert (await ok(client, "/rosapi/has_param", {"name": f"{SLAMWARE}/extra/speed"})) == {
        "exists": False}


async def test_a_fleet_robot_serves_them_under_its_name(make_server, tmp_path):
    robots = (RobotEntry("a", "sim", (6.0, 8.0, 0.0)), RobotEntry("b", "sim", (12.0, 8.0, 0.0)))
    server = await make_server(robots=robots, map_dir=str(tmp_path / "maps"),
                               state_dir=str(tmp_path / "state"))
    c = await WsClient.open(server.port)
    try:
        listed = await ok(c, f"/b{SLAMWARE}/list_parameters", {"prefixes": [], "depth": 1})
        names = (await ok(c, "/rosapi/get_param_names"))["names"]
        assert sorted(listed["result"]["names"]) == sorted(
            n[len(f"/b{SLAMWARE}/"):] for n in names if n.startswith(f"/b{SLAMWARE}/")
            and "/" not in n[len(f"/b{SLAMWARE}/"):])
        assert listed["result"]["names"]
    finally:
        await c.close()

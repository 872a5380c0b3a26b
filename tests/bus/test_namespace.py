"""A robot's view of the bus: names resolved into /NAME/, site-wide names untouched."""

from __future__ import annotations

import pytest

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.namespace import Namespace, NamespacedBus, check_robot_name
from hitrobot_server.nodes.assembly import reserved_names
from hitrobot_server.types.registry import TypeRegistry


def test_names_resolve_into_the_namespace():
    ns = Namespace("alpha")
    assert ns.resolve("/move_base") == "/alpha/move_base"
    assert ns.resolve("cmd_vel") == "/alpha/cmd_vel"
    assert ns.resolve("/slamware_ros_sdk_server_node/odom") == (
        "/alpha/slamware_ros_sdk_server_node/odom")
    assert ns.resolve("/alpha/already") == "/alpha/already"  # idempotent
    assert ns.resolve("/alphabet") == "/alpha/alphabet"
    for site in ("/tf", "/tf_static", "/rosout", "/map", "/map_manager/get_pois",
                 "/fleet/members", "/rosapi/topics"):
        assert ns.resolve(site) == site
    assert ns.resolve("/map/robot_0/Odometry") == "/alpha/map/robot_0/Odometry"
    assert ns.frame("/base_link") == "alpha/base_link"


@pytest.mark.parametrize("name", ["", "1a", "a b", "a/b", "a-b", "x" * 33, "map", "tf",
                                  "hitrobot_client_3"])
def test_bad_names(name):
    with pytest.raises(ValueError, match="robot name"):
        check_robot_name(name, reserved_names())


async def test_a_namespaced_bus_routes_to_the_real_one():
    bus = Bus(TypeRegistry.default())
    view = NamespacedBus(bus, Namespace("beta"))
    got = []
    view.subscribe("/chatter", "std_msgs/String", "k", "/listener", lambda m: got.append(m.msg))
    bus.publish("/beta/chatter", {"data": "hi"})
    view.publish("chatter", {"data": "again"})
    assert [m["data"] for m in got] == ["hi", "again"]
    assert bus.topic("/chatter") is None and view.topic("/chatter") is bus.topic("/beta/chatter")
    assert bus.topics["/beta/chatter"].subscribers["k"][0] == "/beta/listener"

    async def handler(request: dict) -> dict:
        return {"success": True, "message": "ok"}

    view.advertise_service("/trigger", "std_srvs/Trigger", "owner", "/node", handler)
    assert (await bus.call_service("/beta/trigger", {}))["message"] == "ok"
    assert (await view.call_service("/trigger", {}))["success"]
    view.params.set("robot_id", "beta")
    assert bus.params.get("/beta/robot_id") == "beta" and view.params.has("/robot_id")
    view.register_node("/node")
    assert "/beta/node" in bus.nodes and view.node_name("/x") == "/beta/x"

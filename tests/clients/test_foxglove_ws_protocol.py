"""The real Foxglove client (@foxglove/ws-protocol, run by Node) against a live server with the
simulated robot, next to a roslibjs client on the same port."""

from __future__ import annotations

from hitrobot_server.bus.errors import ServiceError
from hitrobot_server.nodes.base import Node
from tests.clients.test_roslibjs import node_modules, run_checks  # noqa: F401  (the fixture is used)

CHECKS = ["server_info", "channels_for_every_topic", "every_channel_decodes",
          "odom_scan_map_tf_at_their_rates",
          "cmd_vel_from_foxglove_turns_the_robot", "cmd_vel_one_driver_at_a_time",
          "service_call", "parameters_get_set_subscribe",
          "connection_graph", "foxglove_and_roslibjs_on_one_topic", "bad_input_gets_error_status",
          "sdk_subprotocol"]


async def test_foxglove_client_suite(make_server, node_modules, tmp_path):  # noqa: F811
    server = await make_server(robot="sim", map_dir=str(tmp_path / "maps"))
    node = Node(server.bus, "/fg_test_node")

    async def add(request: dict) -> dict:
        return {"sum": request["a"] + request["b"]}

    async def fail(request: dict) -> dict:
        raise ServiceError("refused on purpose")

    node.service("/fg/add", "rospy_tutorials/AddTwoInts", add)
    node.service("/fg/fail", "rospy_tutorials/AddTwoInts", fail)
    await run_checks(node_modules / "foxglove_client.mjs", server.port, CHECKS, 120)

"""Foxglove clients see the whole graph, not only their own process's bus: under
``--workers 2`` every client (on either worker) and a client of a Zenoh peer without the robot
are offered the robot's topics and receive ``/scan`` data, with the real
@foxglove/ws-protocol client (tests/js/foxglove_spread.mjs)."""

from __future__ import annotations

import pytest

from tests.bus.test_zenoh_scale_out import free_port, zenoh_server
from tests.clients.test_roslibjs import node_modules, run_checks  # noqa: F401  (the fixture is used)
from tests.helpers import ServerProcess

ROBOT_TOPICS = "/scan,/odom,/map"
CLIENTS = 6


@pytest.fixture(scope="module")
def workers_with_robot():
    server = ServerProcess("--workers", "2", "--log-level", "warning", robot="sim")
    yield server
    server.stop()


async def test_every_foxglove_client_of_either_worker_gets_the_robots_topics(
    workers_with_robot, node_modules  # noqa: F811
):
    checks = ["spread", *(f"client_{i}" for i in range(CLIENTS))]
    await run_checks(node_modules / "foxglove_spread.mjs", workers_with_robot.port, checks, 120,
                     [str(CLIENTS), "2", ROBOT_TOPICS])


async def test_a_foxglove_client_of_a_zenoh_peer_without_the_robot_gets_scan(
    node_modules  # noqa: F811
):
    port = free_port()
    robot = zenoh_server(listen=port, robot="sim")
    try:
        peer = zenoh_server(connect=port)
        try:
            await run_checks(node_modules / "foxglove_spread.mjs", peer.port,
                             ["spread", "client_0", "client_1"], 120, ["2", "1", ROBOT_TOPICS])
        finally:
            peer.stop()
    finally:
        robot.stop()

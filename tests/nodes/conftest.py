"""Fixtures shared by the robot-facing node tests."""

from __future__ import annotations

import pytest

from hitrobot_server.robot.factory import build_simulator
from hitrobot_server.robot.rest.device import SimDevice


@pytest.fixture(params=["sim", "rest"])
def backend(request) -> str:
    return request.param


@pytest.fixture
async def start_robot(make_server, backend):
    """``await start_robot(**settings)``: a server with the simulated robot, in process or
    behind a sim-device over HTTP (the simulator settings then go to the device)."""
    servers, devices = [], []

    async def start(**overrides):
        if backend == "sim":
            return await make_server(robot="sim", **overrides)
        world = overrides.pop("world", None)
        seed = overrides.pop("sim_seed", 0)
        mapping = overrides.pop("sim_mapping", False)
        speed = overrides.pop("sim_speed", 1.0)
        device = SimDevice(build_simulator(world, seed, mapping), port=0, time_scale=speed)
        await device.start()
        devices.append(device)
        server = await make_server(robot=device.url, **overrides)
        servers.append(server)
        return server

    yield start
    for server in servers:  # the server first, so it never sees its robot go away
        await server.stop()
    for device in devices:
        await device.stop()



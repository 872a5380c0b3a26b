"""Fixtures shared by the robot-facing node tests.

``start_robot`` starts a server with the simulated robot, in process ("sim") or behind a
sim-device over HTTP ("rest"); a test that uses it runs once per backend. ``robot`` is the one
ready-made robot of a test module: the module says what it needs in a ``ROBOT = RobotSetup(...)``
(speed, topics to watch, when the robot counts as ready, which backends).
"""

from __future__ import annotations

import pytest

from hitrobot_server.robot.device import SimDevice
from hitrobot_server.robot.factory import build_simulator
from tests.helpers import Watcher, WsClient
from tests.nodes.robot_setup import Robot, RobotSetup

BACKENDS = ("sim", "rest")


@pytest.fixture
def backend() -> str:
    """The simulator in process, unless a test is parametrised over both backends below."""
    return "sim"


def pytest_generate_tests(metafunc):
    """Every test that starts a robot runs per backend; a module's ``robot`` fixture runs on
    the backends its ``ROBOT`` names (the simulator only, unless it says otherwise)."""
    if "backend" in metafunc.fixturenames:
        setup = getattr(metafunc.module, "ROBOT", None)
        use_setup = setup is not None and "robot" in metafunc.fixturenames
        backends = setup.backends if use_setup else BACKENDS
        if backends != ("sim",):
            metafunc.parametrize("backend", backends)


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


@pytest.fixture
async def robot(request, start_robot, tmp_path):
    """The module's robot (its ``ROBOT`` setup), watched and ready."""
    setup: RobotSetup = request.module.ROBOT
    overrides = {"map_dir": str(tmp_path / "maps")} if setup.map_dir else {}
    server = await start_robot(sim_speed=setup.sim_speed, **overrides)
    w = await Watcher.open(server.port)
    for topic, type_name in setup.watch.items():
        await w.subscribe(topic, type_name)
    await w.until(lambda: setup.ready(w), setup.ready_timeout, setup.ready_what)
    c = await WsClient.open(server.port) if setup.client else None
    yield Robot(server, w, c)
    if c is not None:
        await c.close()
    await w.close()

from __future__ import annotations

import os
import shutil
import tempfile

import pytest

from hitrobot_server.config import Settings
from hitrobot_server.server import HitrobotServer
from tests.helpers import ServerProcess, WsClient

_XDG: str | None = None


def pytest_configure(config: pytest.Config) -> None:
    """A safety net under the per-server temporary folders: every server this run starts, in
    process or as a subprocess (which inherits the environment), has its default state and
    data folders in a temporary directory, never the user's real ones."""
    global _XDG
    _XDG = tempfile.mkdtemp(prefix="hitrobot-tests-xdg-")
    os.environ["XDG_STATE_HOME"] = os.path.join(_XDG, "state")
    os.environ["XDG_DATA_HOME"] = os.path.join(_XDG, "data")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Every test of the console (tests/web/) drives a real Chromium: marked ``browser``, so
    ``-m "not browser"`` runs the rest where no browser is installed."""
    for item in items:
        if "web" in item.path.relative_to(item.config.rootpath).parts[:2]:
            item.add_marker(pytest.mark.browser)


def pytest_unconfigure(config: pytest.Config) -> None:
    if _XDG is not None:
        shutil.rmtree(_XDG, ignore_errors=True)


@pytest.fixture
async def make_server(tmp_path_factory):
    """Start real servers on ephemeral loopback ports, each with its own temporary state
    folder (never the user's); stopped after the test."""
    started: list[HitrobotServer] = []

    async def make(**overrides) -> HitrobotServer:
        kw = {"port": 0, "tcp_port": -1, "address": "127.0.0.1", "unregister_timeout": 0.2,
              "robot": "none", "state_dir": str(tmp_path_factory.mktemp("state"))}
        kw.update(overrides)
        server = HitrobotServer(Settings.of(**kw))
        await server.start()
        started.append(server)
        return server

    yield make
    for server in started:
        await server.stop()


@pytest.fixture
async def server(make_server):
    return await make_server()


@pytest.fixture
async def client(server):
    c = await WsClient.open(server.port)
    yield c
    await c.close()


@pytest.fixture(scope="module")
def server_process():
    proc = ServerProcess()
    yield proc
    proc.stop()

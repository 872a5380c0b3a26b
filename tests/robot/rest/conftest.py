"""Shared fixtures: a sim-device on an ephemeral loopback port and a client connected to it,
plus a scriptable fake robot for the failures a simulator never produces."""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable

import pytest
from aiohttp import web

from hitrobot_server.robot.device import SimDevice
from hitrobot_server.robot.factory import build_simulator
from hitrobot_server.robot.rest.client import SlamwareRestBackend


async def connected(backend: SlamwareRestBackend, seconds: float = 5.0) -> None:
    for _ in range(round(seconds / 0.01)):
        if backend.link.connected:
            return
        await asyncio.sleep(0.01)
    raise AssertionError("the client did not connect")


@pytest.fixture
async def device():
    dev = SimDevice(build_simulator(), port=0, time_scale=4.0)
    await dev.start()
    yield dev
    await dev.stop()


@pytest.fixture
async def client(device):
    backend = SlamwareRestBackend(device.url, reconn_wait_ms=200)
    await backend.link.start()
    await connected(backend)
    yield backend
    await backend.link.stop()


class FakeRobot:
    """An aiohttp server answering each (method, path) with a scripted handler; every request
    is recorded. Capabilities answer "ready" unless scripted otherwise."""

    def __init__(self) -> None:
        self.routes: dict[tuple[str, str], Callable[[web.Request], Awaitable[web.Response]]] = {}
        self.seen: list[tuple[str, str]] = []
        self.url = ""
        self._runner: web.AppRunner | None = None

    def on(self, method: str, path: str, handler) -> None:
        self.routes[(method, path)] = handler

    def answer(self, method: str, path: str, body: bytes | str = b"", status: int = 200,
               content_type: str = "application/json") -> None:
        data = body.encode() if isinstance(body, str) else body

        async def handler(request: web.Request) -> web.Response:
            return web.Response(body=data, status=status, content_type=content_type)

        self.on(method, path, handler)

    async def _dispatch(self, request: web.Request) -> web.Response:
        self.seen.append((request.method, request.path))
        handler = self.routes.get((request.method, request.path))
        if handler is None:
            if request.path.endswith("/capabilities"):
                return web.json_response([{"name": "slamware.agent.core", "version": "1",
                                           "enabled": True}])
            return web.Response(status=404, text="Not Found")
        return await handler(request)

    async def start(self) -> None:
        app = web.Application()
        app.router.add_route("*", "/{tail:.*}", self._dispatch)
        self._runner = web.AppRunner(app, access_log=None, shutdown_timeout=0.5)
        await self._runner.setup()
        site = web.TCPSite(self._runner, "127.0.0.1", 0)
        await site.start()
        self.url = f"http://127.0.0.1:{self._runner.addresses[0][1]}"

    async def stop(self) -> None:
        if self._runner is not None:
            await self._runner.cleanup()


@pytest.fixture
async def fake():
    robot = FakeRobot()
    await robot.start()
    yield robot
    await robot.stop()


@pytest.fixture
async def fake_client(fake):
    backend = SlamwareRestBackend(fake.url, reconn_wait_ms=200, timeout=0.3,
                                  control_timeout=0.3, bulk_timeout=0.3)
    await backend.link.start()
    await connected(backend)
    yield backend
    await backend.link.stop()

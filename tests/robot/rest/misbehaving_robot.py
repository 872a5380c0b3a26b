"""A misbehaving Slamware REST robot for issue 52's tests: a sim-device behind a proxy that
answers every request as its mode says -- ``behave`` (forwarded), ``http500``, ``garbage``
(not JSON), ``huge`` (200 MB, chunked) or ``absurd`` (a known area of 1e9 m and a map header
declaring 20000 x 20000 cells, then 200 MB). It runs in its own process
(``python -m tests.robot.rest.misbehaving_robot``, which prints its URL), so what it costs is
not counted as the server's; ``PUT /mode`` with the mode as the body switches it and
``GET /bad`` says how many bad answers it gave.
"""

from __future__ import annotations

import asyncio
import struct
import sys

import aiohttp
from aiohttp import web

from hitrobot_server.robot.device import SimDevice
from hitrobot_server.robot.factory import build_simulator
from hitrobot_server.robot.rest import paths

HUGE = 200 * 1024 * 1024
CHUNK = b"7" * 65536
MODES = ("behave", "http500", "garbage", "huge", "absurd")


class MisbehavingRobot:
    """The proxy in front of a sim-device; :attr:`mode` says how it answers."""

    def __init__(self) -> None:
        self.mode = "behave"
        self.url = ""
        self.bad_answers = 0
        self._device: SimDevice | None = None
        self._runner: web.AppRunner | None = None
        self._session: aiohttp.ClientSession | None = None

    async def start(self) -> None:
        self._device = SimDevice(build_simulator(), port=0, time_scale=4.0)
        await self._device.start()
        self._session = aiohttp.ClientSession()
        app = web.Application(client_max_size=64 * 1024 * 1024)
        app.router.add_put("/mode", self._set_mode)
        app.router.add_get("/bad", self._bad)
        app.router.add_route("*", "/{tail:.*}", self._answer)
        self._runner = web.AppRunner(app, access_log=None, shutdown_timeout=0.5)
        await self._runner.setup()
        site = web.TCPSite(self._runner, "127.0.0.1", 0)
        await site.start()
        port = site._server.sockets[0].getsockname()[1]  # type: ignore[union-attr]
        self.url = f"http://127.0.0.1:{port}"

    async def stop(self) -> None:
        assert self._runner and self._session and self._device
        await self._runner.cleanup()
        await self._session.close()
        await self._device.stop()

    async def _set_mode(self, request: web.Request) -> web.Response:
        mode = (await request.text()).strip()
        if mode not in MODES:
            return web.Response(status=400, text=f"no mode {mode!r}")
        self.mode = mode
        return web.Response(text=mode)

    async def _bad(self, _request: web.Request) -> web.Response:
        return web.Response(text=str(self.bad_answers))

    async def _answer(self, request: web.Request) -> web.StreamResponse:
        mode = self.mode
        if mode == "behave" or (mode == "absurd" and request.path not in (
                paths.KNOWN_AREA, paths.EXPLORE_MAP)):
            return await self._forward(request)
        self.bad_answers += 1
        if mode == "http500":
            return web.Response(status=500, text="internal error: the core agent crashed")
        if mode == "garbage":
            return web.Response(body=b"<html>{oops", content_type="application/json")
        if mode == "absurd" and request.path == paths.KNOWN_AREA:
            return web.json_response({"x": 0.0, "y": 0.0, "width": 1e9, "height": 1e9})
        head = CHUNK[:36]
        if mode == "absurd":  # a map header declaring 20000 x 20000 cells, then 200 MB
            head = struct.pack("<ffIIf12xI", 0.0, 0.0, 20000, 20000, 0.05, 20000 * 20000)
        return await self._stream(request, head)

    async def _stream(self, request: web.Request, head: bytes) -> web.StreamResponse:
        """200 MB, chunked (no Content-Length to refuse it by), until the client hangs up."""
        resp = web.StreamResponse(headers={"Content-Type": "application/json"})
        await resp.prepare(request)
        try:
            await resp.write(head)
            for _ in range(HUGE // len(CHUNK)):
                await resp.write(CHUNK)
            await resp.write_eof()
        except ConnectionError:
            pass  # the client stopped reading: what we want
        return resp

    async def _forward(self, request: web.Request) -> web.Response:
        assert self._session and self._device
        async with self._session.request(
                request.method, self._device.url + request.path_qs, data=await request.read(),
                headers={"Content-Type": request.content_type}) as got:
            return web.Response(body=await got.read(), status=got.status,
                                headers={"Content-Type": got.headers.get(
                                    "Content-Type", "application/json")})


async def serve() -> None:
    robot = MisbehavingRobot()
    await robot.start()
    print(robot.url, flush=True)
    try:
        await asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)  # until closed
    finally:
        await robot.stop()


if __name__ == "__main__":
    asyncio.run(serve())

"""A robot that answers badly (issue 52, item 3): the server talks to a sim-device through a
proxy that can be switched between behaving, HTTP 500, invalid JSON, 200 MB bodies and absurd
map sizes. The server reads each answer only up to its endpoint's bound, says what is wrong
on ``/diagnostics_agg`` and ``/healthz``, keeps its other clients served and its memory, and
publishes the map again once the robot behaves."""

from __future__ import annotations

import asyncio
import json
import os
import struct
import threading

import aiohttp
from aiohttp import web

from hitrobot_server import procmem
from hitrobot_server.nodes.options import SlamwareParams
from hitrobot_server.robot.device import SimDevice
from hitrobot_server.robot.factory import build_simulator
from hitrobot_server.robot.rest import paths

from ...helpers import Watcher
from ...transport.test_http import http
from ...witness import MemoryPeak, RoundTrips

NS = "/slamware_ros_sdk_server_node"
MAP = f"{NS}/map"
HUGE = 200 * 1024 * 1024
CHUNK = b"7" * 65536
MiB = 1024 * 1024


class MisbehavingRobot:
    """A sim-device behind a proxy, both on their own event loop in a thread (so what they
    cost is not the server's loop). :attr:`mode` says how the proxy answers every request."""

    def __init__(self) -> None:
        self.mode = "behave"
        self.url = ""
        self.bad_answers = 0
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, daemon=True)
        self._device: SimDevice | None = None
        self._runner: web.AppRunner | None = None
        self._session: aiohttp.ClientSession | None = None

    async def start(self) -> None:
        self._thread.start()
        await asyncio.wrap_future(asyncio.run_coroutine_threadsafe(self._start(), self._loop))

    async def stop(self) -> None:
        await asyncio.wrap_future(asyncio.run_coroutine_threadsafe(self._stop(), self._loop))
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(5)

    async def _start(self) -> None:
        self._device = SimDevice(build_simulator(), port=0, time_scale=4.0)
        await self._device.start()
        self._session = aiohttp.ClientSession()
        app = web.Application(client_max_size=64 * MiB)
        app.router.add_route("*", "/{tail:.*}", self._answer)
        self._runner = web.AppRunner(app, access_log=None, shutdown_timeout=0.5)
        await self._runner.setup()
        site = web.TCPSite(self._runner, "127.0.0.1", 0)
        await site.start()
        port = site._server.sockets[0].getsockname()[1]  # type: ignore[union-attr]
        self.url = f"http://127.0.0.1:{port}"

    async def _stop(self) -> None:
        assert self._runner and self._session and self._device
        await self._runner.cleanup()
        await self._session.close()
        await self._device.stop()

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


async def health(port: int) -> tuple[int, dict]:
    status, _headers, body = await http(port, "GET", "/healthz")
    return status, json.loads(body)


def connection_item(w: Watcher) -> dict:
    got = w.latest("/diagnostics_agg") or {"status": []}
    return next((s for s in got["status"] if s["name"] == "/Robot/Connection"), {})


def rss() -> int:
    return procmem.memory(os.getpid()).total


async def test_a_robot_answering_errors_nonsense_and_huge_bodies(make_server):
    robot = MisbehavingRobot()
    await robot.start()
    server = await make_server(robot=robot.url, slamware=SlamwareParams(reconn_wait_ms=300))
    w = await Watcher.open(server.port)
    witness = await RoundTrips.open(server.port)
    try:
        await w.subscribe(MAP, "nav_msgs/OccupancyGrid", throttle_rate=500)
        await w.subscribe("/diagnostics_agg")
        await w.until(lambda: w.latest(MAP), 20, "the map")
        await w.until(lambda: connection_item(w).get("message") == "connected", 10,
                      "diagnostics")
        assert (await health(server.port))[0] == 200
        base = rss()
        figures = {}
        for mode, words in (("http500", "HTTP 500"), ("garbage", "not JSON"),
                            ("huge", "bound"), ("absurd", "bound")):
            peak = MemoryPeak(os.getpid())
            robot.mode = mode
            answers = robot.bad_answers

            async def reasoned(words=words) -> str:
                status, got = await health(server.port)
                reasons = [r.get("reason", "") for r in got["robots"]["links"]]
                return (status == 503 and not got["ok"] and not got["robots"]["ok"]
                        and any(words in r for r in reasons)) and reasons[0]

            reason = await until(reasoned, 15, f"/healthz saying the robot answers {mode}")
            assert robot.bad_answers > answers
            await w.until(lambda words=words: connection_item(w).get("level") == 2
                          and words in connection_item(w)["message"], 10,
                          f"/diagnostics_agg reporting {mode}")
            figures[mode] = {"reason": reason}
            robot.mode = "behave"
            w.messages.pop(MAP, None)

            async def healthy() -> bool:
                status, got = await health(server.port)
                return status == 200 and got["ok"]

            await until(healthy, 20, f"/healthz ok again after {mode}")
            await w.until(lambda: w.latest(MAP), 30, f"the map again after {mode}")
            await w.until(lambda: connection_item(w).get("message") == "connected", 10,
                          f"diagnostics connected again after {mode}")
            figures[mode]["peak_mb"] = round((peak.stop() + peak.base - base) / MiB, 1)
            figures[mode]["after_mb"] = round((rss() - base) / MiB, 1)
            assert rss() - base < 50 * MiB, (mode, figures[mode])
            w.messages.pop(MAP, None)
        worst = await witness.stop()
        print("misbehaving robot:", figures, f"witness worst {worst * 1000:.0f} ms")
        assert worst <= 0.5, (worst, witness.times[-50:])
    finally:
        await witness.stop() if witness._thread.is_alive() else None
        await w.close()
        await robot.stop()


async def until(check, timeout: float, what: str):
    """The first true value of ``await check()``, polled every 50 ms for ``timeout`` s."""
    for _ in range(round(timeout / 0.05)):
        value = await check()
        if value:
            return value
        await asyncio.sleep(0.05)
    raise AssertionError(f"timed out after {timeout}s waiting for {what}")

"""A robot that answers badly (issue 52, item 3): the server talks to a sim-device through a
proxy in its own process (:mod:`.misbehaving_robot`) that can be switched between behaving,
HTTP 500, invalid JSON, 200 MB bodies and absurd map sizes. The server reads each answer only
up to its endpoint's bound, says what is wrong on ``/diagnostics_agg`` and ``/healthz``,
keeps its other clients served and its memory, and publishes the map again once the robot
behaves."""

from __future__ import annotations

import asyncio
import json
import os
import struct
import sys
from pathlib import Path

import aiohttp
import numpy as np
import pytest

from hitrobot_server import procmem
from hitrobot_server.nodes.options import SlamwareParams
from hitrobot_server.robot.backend import BackendError
from hitrobot_server.robot.model import MapRegion, Rect
from hitrobot_server.robot.rest import limits, mapformat, paths
from tests.helpers import Watcher
from tests.transport.test_http import http
from tests.witness import MemoryPeak, RoundTrips

NS = "/slamware_ros_sdk_server_node"
MAP = f"{NS}/map"
MiB = 1024 * 1024
ROOT = Path(__file__).resolve().parents[3]


class RobotProcess:
    """:mod:`.misbehaving_robot` in its own process, switched over its control endpoints."""

    def __init__(self, proc: asyncio.subprocess.Process, url: str):
        self.proc, self.url = proc, url

    @classmethod
    async def start(cls) -> RobotProcess:
        proc = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "tests.robot.rest.misbehaving_robot", cwd=ROOT,
            stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE)
        assert proc.stdout is not None
        line = await asyncio.wait_for(proc.stdout.readline(), 30)
        assert line.startswith(b"http://127.0.0.1:"), line
        return cls(proc, line.decode().strip())

    async def _call(self, method: str, path: str, body: str = "") -> str:
        timeout = aiohttp.ClientTimeout(total=10)
        async with aiohttp.ClientSession(timeout=timeout) as http_, http_.request(
                method, self.url + path, data=body) as resp:
            assert resp.status == 200, resp.status
            return await resp.text()

    async def mode(self, mode: str) -> None:
        await self._call("PUT", "/mode", mode)

    async def bad_answers(self) -> int:
        return int(await self._call("GET", "/bad"))

    async def stop(self) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        try:
            await asyncio.wait_for(self.proc.wait(), 10)
        except TimeoutError:
            self.proc.kill()
            await self.proc.wait()


async def health(port: int) -> tuple[int, dict]:
    status, _headers, body = await http(port, "GET", "/healthz")
    return status, json.loads(body)


def connection_item(w: Watcher) -> dict:
    got = w.latest("/diagnostics_agg") or {"status": []}
    return next((s for s in got["status"] if s["name"] == "/Robot/Connection"), {})


def rss() -> int:
    return procmem.memory(os.getpid()).total


@pytest.mark.serial  # the witness's and the memory's bounds: run alone (tests/run.py)
async def test_a_robot_answering_errors_nonsense_and_huge_bodies(make_server):
    robot = await RobotProcess.start()
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
            await robot.mode(mode)
            answers = await robot.bad_answers()

            async def reasoned(words=words) -> str:
                status, got = await health(server.port)
                reasons = [r.get("reason", "") for r in got["robots"]["links"]]
                return (status == 503 and not got["ok"] and not got["robots"]["ok"]
                        and any(words in r for r in reasons)) and reasons[0]

            reason = await until(reasoned, 15, f"/healthz saying the robot answers {mode}")
            assert await robot.bad_answers() > answers
            await w.until(lambda words=words: connection_item(w).get("level") == 2
                          and words in connection_item(w)["message"], 10,
                          f"/diagnostics_agg reporting {mode}")
            figures[mode] = {"reason": reason}
            await robot.mode("behave")
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


async def test_each_answer_is_read_up_to_its_endpoints_bound(fake, fake_client):
    """The bounds of :mod:`hitrobot_server.robot.rest.limits`, one endpoint at a time, and the
    link's trouble naming the latest bad answer until its endpoint answers well again."""
    link = fake_client.link
    assert link.trouble == ""
    # a stated size over the bound is refused unread
    fake.answer("GET", paths.POSE, b" " * (limits.JSON_LIMIT + 1))
    with pytest.raises(BackendError, match=f"states {limits.JSON_LIMIT + 1} bytes"):
        await fake_client.localization.get_pose()
    assert paths.POSE in link.trouble and "bound" in link.trouble
    # a list may be bigger than a pose, up to its own bound
    scan = {"pose": {"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0},
            "laser_points": [{"distance": 1.0, "angle": 0.0, "valid": True}] * 30_000}
    fake.answer("GET", paths.LASERSCAN, json.dumps(scan))
    assert limits.JSON_LIMIT < len(json.dumps(scan)) < limits.LIST_LIMIT
    assert len((await fake_client.sensors.get_laser_scan()).ranges) == 30_000  # parsed off-loop
    # an explore map's header declaring more cells than the bound is refused after 36 bytes
    side = 8193
    header = struct.pack("<ffIIf12xI", 0.0, 0.0, side, side, 0.05, side * side)
    fake.answer("GET", paths.EXPLORE_MAP, header + b"\0" * 1024, 200, "application/octet-stream")
    with pytest.raises(BackendError, match="over the bound of 67108864 cells"):
        await fake_client.maps.get_map(Rect(0.0, 0.0, 1.0, 1.0))
    # a known area the map could not hold at its resolution
    fake.answer("GET", paths.KNOWN_AREA, json.dumps({"x": 0, "y": 0, "width": 500.0,
                                                     "height": 500.0}))
    with pytest.raises(BackendError, match="known area of 500 x 500 m"):
        await fake_client.maps.get_known_area()
    assert paths.KNOWN_AREA in link.trouble and "2 other endpoints" in link.trouble
    # the same endpoints answering well: no trouble left
    fake.answer("GET", paths.POSE, json.dumps({"x": 1.0, "y": 2.0, "z": 0.0, "yaw": 0.5}))
    fake.answer("GET", paths.KNOWN_AREA, json.dumps({"x": 0, "y": 0, "width": 5.0,
                                                     "height": 5.0}))
    fake.answer("GET", paths.EXPLORE_MAP, mapformat.encode(MapRegion(
        0.0, 0.0, 0.05, np.zeros((4, 4), dtype=np.uint8))), 200, "application/octet-stream")
    assert (await fake_client.localization.get_pose()).x == 1.0
    assert (await fake_client.maps.get_known_area()).width == 5.0
    assert (await fake_client.maps.get_map(Rect(0.0, 0.0, 1.0, 1.0))).cells.shape == (4, 4)
    assert link.trouble == ""
    assert link.connected  # it answered all along

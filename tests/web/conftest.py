"""Playwright (async) driving Debian's Chromium against a real hitrobot-server with the simulator.

Browsers cannot be downloaded here, so Playwright launches ``/usr/bin/chromium`` (``apt-get
install chromium``; .ci/run does it) with a fresh profile per test. The console's libraries
come from ``npm ci --prefix web``.
"""

from __future__ import annotations

import io
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.helpers import Watcher

REPO = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO / "test-artifacts"
CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]
VIEWPORT = {"width": 1440, "height": 900}
READY = """() => {
  const h = window.hitrobot;
  return Boolean(h && h.view.mapBounds && h.state.pose && h.ros.isConnected &&
    document.getElementById('mode').dataset.mode !== 'unknown');
}"""


@dataclass
class Console:
    """The page, the server behind it, and every error the page showed on its console."""

    page: object
    server: object
    errors: list[str] = field(default_factory=list)
    ops: set[str] = field(default_factory=set)  # the ops of the frames the page received

    async def screenshot_array(self) -> np.ndarray:
        png = await self.page.screenshot()
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)

    async def to_client(self, x: float, y: float) -> tuple[float, float]:
        """A map point on the page, through the page's own transform."""
        p = await self.page.evaluate("([x, y]) => window.hitrobot.view.rosToClient(x, y)", [x, y])
        return p["x"], p["y"]

    async def frame(self) -> None:
        """Wait until the page has painted what it has (two animation frames + a tick)."""
        await self.page.evaluate(
            "() => new Promise(r => setTimeout(() => requestAnimationFrame(() => "
            "requestAnimationFrame(r)), 60))")

    async def wait_data(self, selector: str, key: str, value: str, timeout: float = 10) -> None:
        """Wait until ``selector``'s ``data-<key>`` is ``value``."""
        await self.page.wait_for_function(
            "([sel, key, value]) => document.querySelector(sel).dataset[key] === value",
            arg=[selector, key, value], timeout=timeout * 1000)

    async def snapshot(self, name: str) -> None:
        """Save the page as test-artifacts/<name>.png; with UPDATE_SCREENSHOT=1 also as the
        README's web/<name>.png."""
        await self.frame()
        ARTIFACTS.mkdir(exist_ok=True)
        png = await self.page.screenshot(path=str(ARTIFACTS / f"{name}.png"))
        if os.environ.get("UPDATE_SCREENSHOT") == "1":
            (REPO / "web" / f"{name}.png").write_bytes(png)

    async def tab(self, name: str) -> None:
        """Show a tab of the side panel (Operate, Map, Status, Inspect)."""
        await self.page.click(f".tabs [data-tab={name}]")
        await self.page.locator(f"[data-tab-panel={name}]").wait_for(state="visible")

    async def drag(self, start: tuple[float, float], end: tuple[float, float]) -> None:
        await self.page.mouse.move(*start)
        await self.page.mouse.down()
        await self.page.mouse.move(*end, steps=6)
        await self.page.mouse.up()


@pytest.fixture
async def browser(tmp_path):
    if not CHROMIUM.exists():
        raise RuntimeError("Chromium is not installed: `apt-get install -y chromium` "
                           "(.ci/run does this)")
    if not (REPO / "web" / "node_modules" / "roslib").is_dir():
        raise RuntimeError("the console's libraries are missing: run `npm ci --prefix web` "
                           "(.ci/run does this)")
    from playwright.async_api import async_playwright

    async with async_playwright() as pw:
        context = await pw.chromium.launch_persistent_context(
            str(tmp_path / "chromium-profile"), executable_path=str(CHROMIUM),
            args=CHROMIUM_ARGS, headless=True, viewport=VIEWPORT,
        )
        try:
            yield context
        finally:
            await context.close()


@pytest.fixture
async def console(make_server, browser, tmp_path):
    server = await make_server(robot="sim", sim_speed=4, map_dir=str(tmp_path / "maps"))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    errors: list[str] = []
    page.on("console", lambda m: errors.append(f"console.{m.type}: {m.text}")
            if m.type in ("error", "warning") else None)
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    page.on("requestfailed", lambda r: errors.append(f"request failed: {r.url} {r.failure}"))
    page.on("response", lambda r: errors.append(f"HTTP {r.status}: {r.url}")
            if r.status >= 400 else None)
    result = Console(page, server, errors)

    def on_frame(payload):
        text = payload if isinstance(payload, str) else ""
        if m := re.match(r'\{\s*"op"\s*:\s*"(\w+)"', text):
            result.ops.add(m.group(1))

    page.on("websocket", lambda ws: ws.on("framereceived", on_frame))
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.wait_for_function(READY, timeout=30_000)
    yield result


@pytest.fixture
async def watcher(console):
    w = await Watcher.open(console.server.port)
    yield w
    await w.close()


def yaw_of(q: dict) -> float:
    return math.atan2(2 * (q["w"] * q["z"] + q["x"] * q["y"]),
                      1 - 2 * (q["y"] ** 2 + q["z"] ** 2))


class GridMap:
    """The /map OccupancyGrid as an array, with metre ↔ cell helpers."""

    def __init__(self, msg: dict):
        info = msg["info"]
        self.res = info["resolution"]
        self.ox = info["origin"]["position"]["x"]
        self.oy = info["origin"]["position"]["y"]
        self.cells = np.asarray(msg["data"], dtype=np.int16).reshape(info["height"], info["width"])

    def centre(self, row: int, col: int) -> tuple[float, float]:
        return self.ox + (col + 0.5) * self.res, self.oy + (row + 0.5) * self.res

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return int((y - self.oy) // self.res), int((x - self.ox) // self.res)

    def interior(self, value: int, margin: int) -> list[tuple[int, int]]:
        """Cells whose whole (2·margin+1)² neighbourhood has ``value``."""
        same = self.cells == value
        h, w = same.shape
        ok = np.ones_like(same)
        for dr in range(-margin, margin + 1):
            for dc in range(-margin, margin + 1):
                shifted = np.zeros_like(same)
                shifted[max(0, -dr):h - max(0, dr), max(0, -dc):w - max(0, dc)] = \
                    same[max(0, dr):h - max(0, -dr), max(0, dc):w - max(0, -dc)]
                ok &= shifted
        return list(zip(*np.nonzero(ok), strict=True))

    def clear(self, x: float, y: float, radius: float) -> bool:
        r, c = self.cell(x, y)
        k = math.ceil(radius / self.res)
        if r - k < 0 or c - k < 0 or r + k >= self.cells.shape[0] or c + k >= self.cells.shape[1]:
            return False
        return bool((self.cells[r - k:r + k + 1, c - k:c + k + 1] == 0).all())

    def nearest_clear(self, x: float, y: float, radius: float = 0.45) -> tuple[float, float]:
        """The free point nearest to (x, y) with ``radius`` of free space around it."""
        step = self.res * 2
        for ring in range(0, 200):
            for i in range(-ring, ring + 1):
                for j in (-ring, ring) if abs(i) != ring else range(-ring, ring + 1):
                    px, py = x + i * step, y + j * step
                    if self.clear(px, py, radius):
                        return px, py
        raise AssertionError(f"no free point near ({x}, {y})")


async def add_poi(watcher: Watcher, name: str, x: float, y: float) -> None:
    """A POI facing +x, added by another client (as an operator elsewhere would)."""
    await watcher.publish("/map_manager/add_poi", {
        "type": 100, "name": name, "remarks": "",
        "pose": {"position": {"x": x, "y": y, "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
    }, "map_messages/PointOfInterest")


async def grid_map(watcher: Watcher) -> GridMap:
    await watcher.subscribe("/map", "nav_msgs/OccupancyGrid")
    await watcher.until(lambda: watcher.latest("/map"), 15, "/map")
    return GridMap(watcher.latest("/map"))

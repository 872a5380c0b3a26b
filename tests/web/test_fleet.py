"""The console's fleet view in Chromium against a server with two named simulated robots:
both drawn in their own colours, the drive pad driving the chosen robot only, a POI dispatched
to the nearer robot, the task list."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitrobot_server.robot.options import RobotEntry

from ..helpers import Watcher
from .conftest import Console, add_poi

Y = 8.0
RED, GREEN = (0xE5, 0x39, 0x35), (0x43, 0xA0, 0x47)  # FLEET_COLORS[0], [1]


@pytest.fixture
async def fleet_console(make_server, browser, tmp_path):
    server = await make_server(
        robots=(RobotEntry("a", "sim", (4.0, Y, 0.0)), RobotEntry("b", "sim", (12.0, Y, 0.0))),
        sim_speed=3, map_dir=str(tmp_path / "maps"))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    page.on("console", lambda m: errors.append(f"console.{m.type}: {m.text}")
            if m.type == "error" else None)
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.wait_for_function("""() => {
        const h = window.hitrobot;
        return Boolean(h && h.view.mapBounds && h.ros.isConnected && h.fleet.robots.length === 2
            && h.fleet.robots.every((r) => r.state === 'idle'));
    }""", timeout=30_000)
    yield Console(page, server, errors)


def pose_of(w: Watcher, robot: str) -> tuple[float, float]:
    p = w.latest(f"/{robot}/robot_pose")["position"]
    return p["x"], p["y"]


async def test_select_a_robot_and_drive_it(fleet_console: Console):
    c = fleet_console
    page = c.page
    assert await page.locator("#fleet-panel").is_visible()
    assert await page.locator("#fleet-robots li").count() == 2
    assert await page.get_attribute("#fleet-panel", "data-selected") == "a"

    await c.frame()  # each robot in its own colour at its pose
    img = await c.screenshot_array()
    for colour, x in ((RED, 4.0), (GREEN, 12.0)):
        px, py = await c.to_client(x, Y)
        patch = img[int(py) - 4:int(py) + 5, int(px) - 12:int(px) + 13]
        assert (np.linalg.norm(patch - np.asarray(colour), axis=2) < 60).any(), (colour, x)

    w = await Watcher.open(c.server.port)
    try:
        for robot in ("a", "b"):
            await w.subscribe(f"/{robot}/robot_pose")
        await w.until(lambda: w.latest("/a/robot_pose") and w.latest("/b/robot_pose"), 10,
                      "both poses")
        await page.check("#fleet-robots input[value=b]")
        await page.wait_for_function(
            "() => document.querySelector('#fleet-panel').dataset.selected === 'b'")
        pad = page.locator("#pad [data-drive=fwd]")
        await pad.scroll_into_view_if_needed()
        box = await pad.bounding_box()
        await page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        await page.mouse.down()
        try:
            await w.until(lambda: pose_of(w, "b")[0] > 12.4, 15, "b driving forward")
        finally:
            await page.mouse.up()
        ax, ay = pose_of(w, "a")
        assert math.hypot(ax - 4.0, ay - Y) < 0.05  # a never moved
        assert all(math.hypot(m["position"]["x"] - 4.0, m["position"]["y"] - Y) < 0.05
                   for _, m in w.messages["/a/robot_pose"])
    finally:
        await w.close()
    assert c.errors == []


async def test_dispatch_to_a_poi_sends_the_nearer_robot(fleet_console: Console):
    c = fleet_console
    page = c.page
    w = await Watcher.open(c.server.port)
    try:
        await w.subscribe("/b/robot_pose")
        await add_poi(w, "east", 14.0, Y)
        await page.locator("[data-dispatch=east]").click()
        await page.wait_for_function(
            "() => document.querySelector('#fleet-reply').dataset.robot === 'b'",
            timeout=15_000)
        assert await page.get_attribute("#fleet-reply", "data-accepted") == "true"
        await page.locator("#fleet-tasks li[data-state=succeeded]").wait_for(timeout=30_000)
        text = await page.text_content("#fleet-tasks li[data-state=succeeded]")
        assert "east" in text and "(b)" in text
        await w.until(lambda: w.latest("/b/robot_pose") and math.hypot(
            pose_of(w, "b")[0] - 14.0, pose_of(w, "b")[1] - Y) < 0.3, 10, "b at the POI")
        await c.snapshot("console-fleet")
    finally:
        await w.close()
    assert c.errors == []


async def test_the_goal_tool_sends_the_selected_robot(fleet_console: Console):
    c = fleet_console
    page = c.page
    w = await Watcher.open(c.server.port)
    try:
        for robot in ("a", "b"):
            await w.subscribe(f"/{robot}/robot_pose")
        await w.until(lambda: w.latest("/a/robot_pose") and w.latest("/b/robot_pose"), 10,
                      "both poses")
        await page.check("#fleet-robots input[value=b]")
        sx, sy = await c.to_client(10.0, Y)
        await page.click("[data-tool=goal]")
        await c.drag((sx, sy), (sx - 50, sy))  # drag left on the screen: face -x (west)
        await c.wait_data("#goal-status", "status", "succeeded", timeout=30)
        bx, by = pose_of(w, "b")
        assert math.hypot(bx - 10.0, by - Y) < 0.3
        assert all(math.hypot(m["position"]["x"] - 4.0, m["position"]["y"] - Y) < 0.05
                   for _, m in w.messages["/a/robot_pose"])  # a stayed where it was
    finally:
        await w.close()
    assert c.errors == []

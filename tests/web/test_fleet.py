"""The console's fleet view in Chromium against a server with two named simulated robots:
both drawn in their own colours, the drive pad driving the chosen robot only, a POI dispatched
to the nearer robot, the task list."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hitrobot_server.robot.options import RobotEntry
from tests.helpers import Watcher
from tests.web.conftest import Console, add_poi

Y = 8.0
RED, GREEN = (0xE5, 0x39, 0x35), (0x43, 0xA0, 0x47)  # FLEET_COLORS[0], [1]
FAINT = 0.45  # fleet.js: the robots not chosen are drawn at this opacity
ROBOT = (0x21, 0x96, 0xF3)  # COLORS.robot: the chosen robot's pose marker (RobotMarker)


def faint(colour: tuple[int, int, int]) -> tuple[float, ...]:
    """``colour`` at FAINT opacity over the map's white floor."""
    return tuple(FAINT * v + (1 - FAINT) * 255 for v in colour)


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

    await c.frame()  # each robot in its own colour at its pose: the chosen one (a) in full,
    img = await c.screenshot_array()  # the other fainter (issue 34: "others drawn fainter")
    for colours, x in (((RED, ROBOT), 4.0), ((faint(GREEN),), 12.0)):
        px, py = await c.to_client(x, Y)
        patch = img[int(py) - 4:int(py) + 5, int(px) - 12:int(px) + 13]
        assert any((np.linalg.norm(patch - np.asarray(colour), axis=2) < 60).any()
                   for colour in colours), (colours, x)

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


SCAN = (0xFF, 0x6D, 0x00)  # COLORS.scan


async def scan_pixels(c: Console, x: float, y: float, half: float = 1.0) -> int:
    """How many laser-coloured pixels the page draws within ``half`` m of (x, y)."""
    img = await c.screenshot_array()
    x0, y0 = await c.to_client(x - half, y + half)
    x1, y1 = await c.to_client(x + half, y - half)
    patch = img[int(y0):int(y1), int(x0):int(x1)]
    return int((np.linalg.norm(patch - np.asarray(SCAN), axis=2) < 40).sum())


def colour_near(img: np.ndarray, at: tuple[float, float], colour, tol: float = 40) -> bool:
    px, py = at
    patch = img[int(py) - 6:int(py) + 7, int(px) - 6:int(px) + 7]
    return bool((np.linalg.norm(patch - np.asarray(colour), axis=2) < tol).any())


async def test_the_page_follows_the_selected_robot(fleet_console: Console):
    """Top bar (name, battery, localization), the Navigation panel, the laser and the pose of
    the chosen robot; the other robot drawn fainter. Then back to the first robot."""
    c = fleet_console
    page = c.page
    at = {"a": 4.0, "b": 12.0}
    colour = {"a": RED, "b": GREEN}
    for chosen, other in (("b", "a"), ("a", "b")):
        await page.check(f"#fleet-robots input[value={chosen}]")
        await page.wait_for_function(
            """(name) => {
              const text = (id) => document.querySelector(id).textContent;
              return text('#robot-state').includes(`${name} · connected`)
                && /\\d+%/.test(text('#battery')) && /\\d+/.test(text('#localization .value'))
                && text('#robot-pose').startsWith(`${name} at `);
            }""", arg=chosen, timeout=15_000)
        assert await page.text_content("#goal-status") == f"No goal sent to {chosen}"
        pose = await page.text_content("#robot-pose")
        assert pose.startswith(f"{chosen} at {at[chosen]:.2f}, {Y:.2f} m"), pose
        # the chosen robot's laser: dense around it, sparse around the other
        await page.wait_for_function(
            "(x) => { const p = window.hitrobot.layers.scan.points; return p.length > 100 && "
            "Math.abs(p.reduce((s, v, i) => (i % 2 ? s : s + v), 0) / (p.length / 2) - x) < 4; }",
            arg=at[chosen], timeout=10_000)
        await c.frame()
        near, far = (await scan_pixels(c, at[chosen], Y), await scan_pixels(c, at[other], Y))
        assert near > 40 and near > 3 * far, (chosen, near, far)
        spots = {name: await c.to_client(at[name], Y) for name in at}
        await c.frame()
        img = await c.screenshot_array()
        assert colour_near(img, spots[chosen], colour[chosen]) or \
            colour_near(img, spots[chosen], ROBOT), chosen  # in full colour, or its pose marker
        assert not colour_near(img, spots[other], colour[other], 25), other  # fainter
        assert colour_near(img, spots[other], faint(colour[other])), other
    assert c.errors == []


async def test_dispatch_to_a_chosen_robot_and_out_of_service(fleet_console: Console):
    c = fleet_console
    page = c.page
    w = await Watcher.open(c.server.port)
    try:
        await add_poi(w, "east", 14.0, Y)  # nearer b; the operator sends a
        await page.select_option("#fleet-send", "a")
        await page.locator("[data-dispatch=east]").click()
        await page.wait_for_function(
            "() => document.querySelector('#fleet-reply').dataset.robot === 'a'", timeout=15_000)
        assert await page.get_attribute("#fleet-reply", "data-accepted") == "true"
        await page.locator("#fleet-tasks li[data-state=running]").wait_for(timeout=10_000)
        assert "(a)" in await page.text_content("#fleet-tasks li[data-state=running]")
    finally:
        await w.close()
    # a robot taken out of service (FleetRobot.in_service, which /fleet/set_in_service sets on a
    # server that has it) is listed and drawn as such: the page's own renderer, fed the live list
    # (read in the same turn: the next /fleet/robots, 2 Hz, redraws the list as the server has it)
    service, text = await page.evaluate("""() => {
        const f = window.hitrobot.fleet;
        f.onRobots(f.robots.map((r) => ({ ...r, in_service: r.name !== 'b' })));
        const item = document.querySelector('#fleet-robots li[data-robot=b]');
        return [item.dataset.service, item.textContent];
    }""")
    assert service == "out" and "b — out of service" in text, (service, text)
    assert c.errors == []


async def test_a_dispatch_reply_is_replaced_when_its_task_fails(fleet_console: Console):
    """Issue 46, friction 7: "task N: a is on its way" used to stay after task N failed; the
    Operate tab's reply says what happened instead."""
    c = fleet_console
    page = c.page
    w = await Watcher.open(c.server.port)
    try:
        await add_poi(w, "west", 9.0, Y)
        await page.select_option("#fleet-send", "a")
        await page.locator("[data-dispatch=west]").click()
        await page.wait_for_function(
            "() => document.querySelector('#fleet-reply').dataset.robot === 'a'", timeout=15_000)
        task = await page.get_attribute("#fleet-reply", "data-task")
        assert (await page.text_content("#fleet-reply")).startswith(
            f"task {task}: a is on its way")
        await page.locator("#fleet-tasks li[data-state=running]").wait_for(timeout=10_000)
        await w.subscribe("/fleet/robots")
        await w.until(lambda: any(r["name"] == "a" and r["state"] == "moving" for r in (
            w.latest("/fleet/robots") or {"robots": []})["robots"]), 10, "a moving")
        assert (await w.call("/a/sit_down"))["values"]["success"]
        await page.locator(f"#fleet-tasks li[data-task='{task}'][data-state=failed]").wait_for(
            timeout=15_000)
        reply = page.locator("#fleet-reply[data-state=failed]")
        await reply.wait_for(timeout=5_000)
        text = await reply.text_content()
        assert text.startswith(f"task {task} failed: a failed") and "on its way" not in text, text
    finally:
        await w.close()
    assert c.errors == []

"""Two consoles on one server: a page that only watched never stops the robot (it sends a stop
only when it is the one driving), and a page that does take the robot over is named, as a
warning, on the page whose goal it cancelled."""

from __future__ import annotations

import pytest

from tests.web.conftest import READY, Console, grid_map

ODOM = "/slamware_ros_sdk_server_node/odom"


async def open_second(console: Console, browser):
    """Console B: another tab on the same server, loaded and connected."""
    page = await browser.new_page()
    await page.goto(f"http://127.0.0.1:{console.server.port}/")
    await page.wait_for_function(READY, timeout=30_000)
    return page


async def send_far_goal(console: Console, watcher) -> None:
    """Console A sends a goal across the office (long enough to outlive what B does)."""
    page = console.page
    grid = await grid_map(watcher)
    gx, gy = grid.nearest_clear(19.0, 12.5)
    await page.click("[data-tool=goal]")
    sx, sy = await console.to_client(gx, gy)
    await page.mouse.click(sx, sy)
    await console.wait_data("#goal-status", "status", "active", timeout=15)


@pytest.mark.parametrize("leaves", ["closes", "hidden and blurred"])
async def test_a_console_that_only_watched_never_stops_the_robot(console: Console, watcher,
                                                                  browser, leaves):
    await send_far_goal(console, watcher)
    other = await open_second(console, browser)
    if leaves == "hidden and blurred":
        await other.evaluate("""() => {
            Object.defineProperty(document, 'hidden', { configurable: true, get: () => true });
            document.dispatchEvent(new Event('visibilitychange'));
            window.dispatchEvent(new Event('blur'));
            window.dispatchEvent(new Event('pagehide'));
        }""")
        assert await other.text_content("#drive-state") == "stopped"
    await other.close()
    # A's goal still arrives, as A shows it
    page = console.page
    await page.wait_for_function("""() => ['succeeded', 'preempted', 'aborted']
        .includes(document.querySelector('#goal-status').dataset.status)""", timeout=90_000)
    assert await page.get_attribute("#goal-status", "data-status") == "succeeded"
    assert "SUCCEEDED" in await page.text_content("#goal-status")
    assert await page.locator("#log li", has_text="superseded").count() == 0
    assert await page.locator("#log li", has_text="goal cancelled").count() == 0


async def test_a_console_that_takes_the_robot_over_is_named_as_a_warning(console: Console,
                                                                          watcher, browser):
    await send_far_goal(console, watcher)
    other = await open_second(console, browser)
    await other.locator("#map").focus()
    await other.keyboard.down("ArrowUp")  # B drives: that does take the robot over
    await console.wait_data("#goal-status", "status", "preempted", timeout=15)
    await other.keyboard.up("ArrowUp")
    entry = console.page.locator("#log li.warning", has_text="goal cancelled")
    await entry.first.wait_for(timeout=10_000)
    text = await entry.first.text_content()
    assert "/cmd_vel" in text and "another client" not in text, text
    await other.close()


async def test_a_patrol_outlives_a_watching_console_and_names_who_took_it_over(
        console: Console, watcher, browser):
    page = console.page
    await page.click("[data-tool=waypoint]")
    # two corridor spots of the office, known and free from the start (as the console's patrol
    # journey uses): each click is placed, and listed, before the next
    for i, (x, y) in enumerate(((11.0, 8.0), (7.0, 8.6))):
        sx, sy = await console.to_client(x, y)
        await page.mouse.click(sx, sy)
        await page.locator("#waypoint-list li").nth(i).wait_for(timeout=10_000)
    await page.evaluate("() => document.getElementById('patrol-start').click()")
    await console.wait_data("#patrol-state", "active", "true", timeout=15)
    await console.wait_data("#patrol-state", "target", "0")
    other = await open_second(console, browser)
    await other.close()  # B only watched
    # the patrol goes on: the robot reaches waypoint 1 and heads for waypoint 2
    await console.wait_data("#patrol-state", "target", "1", timeout=90)
    assert await page.get_attribute("#patrol-state", "data-active") == "true"
    other = await open_second(console, browser)
    await other.locator("#map").focus()
    await other.keyboard.down("ArrowUp")  # B drives: that takes the robot over
    await console.wait_data("#patrol-state", "active", "false", timeout=15)
    await other.keyboard.up("ArrowUp")
    entry = page.locator("#log li.warning", has_text="taken over by a /cmd_vel")
    await entry.first.wait_for(timeout=10_000)
    assert "patrol" in await entry.first.text_content()
    await other.close()


async def test_choosing_another_robot_never_stops_the_one_left(make_server, browser, tmp_path):
    """Fleet: b runs a task; the operator clicks b's radio button, then a's. The page never
    drove b, so leaving it sends no stop: b's task still succeeds, as the page lists it."""
    from hitrobot_server.robot.options import RobotEntry
    from tests.helpers import Watcher
    from tests.nodes.fleet.test_node import dispatch, pose

    y = 8.0
    server = await make_server(
        robots=(RobotEntry("a", "sim", (4.0, y, 0.0)), RobotEntry("b", "sim", (12.0, y, 0.0))),
        sim_speed=1, map_dir=str(tmp_path / "maps"))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.wait_for_function("""() => {
        const h = window.hitrobot;
        return Boolean(h && h.view.mapBounds && h.ros.isConnected && h.fleet.robots.length === 2
            && h.fleet.robots.every((r) => r.state === 'idle'));
    }""", timeout=30_000)
    w = await Watcher.open(server.port)
    try:
        got = await dispatch(w, target=pose(8.0, y), robot="b")
        assert got["accepted"] and got["robot"] == "b", got
        await page.locator("#fleet-tasks li[data-state=running]").wait_for(timeout=10_000)
        for name in ("b", "a"):
            await page.check(f"#fleet-robots input[value={name}]")
            await page.wait_for_function(
                "(n) => document.querySelector('#fleet-panel').dataset.selected === n",
                arg=name)
        done = page.locator("#fleet-tasks li[data-state=succeeded]")
        await done.wait_for(timeout=40_000)
        assert "(b)" in await done.text_content()
        assert await page.locator("#fleet-tasks li[data-state=failed]").count() == 0
    finally:
        await w.close()

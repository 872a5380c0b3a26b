"""A goal or a patrol waypoint where the robot cannot stand (on a table, against a wall) is
refused at once on the console, with the reason, by the same rule as a POI (placement.py,
placement.js): nothing is sent, the robot does not move."""

from __future__ import annotations

from tests.web.conftest import Console, grid_map
from tests.web.test_journeys import CLEAR, west_of_clear


def on_an_obstacle(grid_msg: dict) -> tuple[float, float]:
    """An occupied cell's centre west of CLEAR (a table or a wall of the office world)."""
    return west_of_clear(grid_msg, "on an obstacle", 200)


async def test_a_goal_on_an_obstacle_is_refused_at_once(console: Console, watcher):
    page = console.page
    await grid_map(watcher)
    x, y = on_an_obstacle(watcher.latest("/map"))
    await page.click("[data-tool=goal]")
    sx, sy = await console.to_client(x, y)
    await page.mouse.click(sx, sy)
    entry = page.locator("#log li.error", has_text="goal refused")
    await entry.wait_for(timeout=5_000)
    assert "on an obstacle" in await entry.text_content()
    assert await page.get_attribute("#goal-status", "data-status") == "rejected"
    assert "on an obstacle" in await page.text_content("#goal-status")
    assert await page.locator("#log li", has_text="goal sent").count() == 0
    assert await page.locator("#cancel-goal").is_disabled()


async def test_a_waypoint_on_an_obstacle_is_refused(console: Console, watcher):
    page = console.page
    await grid_map(watcher)
    x, y = on_an_obstacle(watcher.latest("/map"))
    await page.click("[data-tool=waypoint]")
    sx, sy = await console.to_client(x, y)
    await page.mouse.click(sx, sy)
    entry = page.locator("#log li.error", has_text="waypoint refused")
    await entry.wait_for(timeout=5_000)
    assert "on an obstacle" in await entry.text_content()
    # a free spot is still taken, so the route has that one only
    fx, fy = await console.to_client(*CLEAR)
    await page.mouse.click(fx, fy)
    await page.locator("#waypoint-list li").first.wait_for(timeout=5_000)
    assert await page.locator("#waypoint-list li").count() == 1

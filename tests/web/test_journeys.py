"""Operator journeys in Chromium that no other module covers, each asserting on what the page
shows (text, element state, pixels of the map), with one server per test.

Which test covers which journey of issue 34 (item 7):

* drive — test_console.py::test_arrow_keys_drive_and_release_stops,
  test_fleet.py::test_select_a_robot_and_drive_it (the drive pad)
* goal and cancel — test_console.py::test_goal_dragged_on_the_map_takes_the_robot_there,
  test_console.py::test_cancel_stops_the_goal,
  test_dialog_keys.py::test_cancelled_goal_and_angle_words
* POIs — test_console.py::test_poi_added_renamed_and_deleted_in_the_page,
  test_console_tools.py::test_poi_go_is_followed_and_can_be_cancelled, and here
  test_a_poi_beside_an_obstacle_is_warned_while_placing_and_refused
* walls and tracks — test_walls_drawn.py (pixels of each segment),
  test_console_tools.py::test_a_wall_drawn_in_the_page_makes_the_planned_path_detour
* save and load a map — test_console_tools.py::test_save_as_then_load_a_saved_map_from_the_list
* relocalize — test_console_tools.py::test_relocalize_raises_a_low_localization_quality,
  test_console_polish.py::test_relocalize_sends_a_complete_request_and_raises_no_toast
* dock — test_console_tools.py::test_go_home_docks_and_the_page_shows_charging
* a patrol — test_console_tools.py::test_patrol_of_three_clicked_waypoints_visits_them_in_order
* record then replay — test_console_recordings.py (both tests)
* restart then restored —
  test_state_notice.py::test_the_console_says_started_fresh_then_restored_once,
  test_console.py::test_page_comes_back_after_the_server_restarts
* two robots and a dispatch — test_fleet.py (the view follows the chosen robot; dispatch to
  the best robot and to a chosen one)
* the README's screenshot and the Messages panel in plain words — here
  test_the_console_at_work_in_plain_words
"""

from __future__ import annotations

import re

import numpy as np

from hitrobot_server.nodes.ground.placement import placement_problem
from hitrobot_server.nodes.map_manager.layers import Grid
from tests.web.conftest import Console, add_poi, grid_map

POIS = "/map_manager/pois"
POI_COLOUR = (0xFF, 0xC4, 0x00)  # COLORS.poi
CLEAR = (11.5, 2.0)  # 0.3 m and more from every obstacle of the office world
DEVELOPER_SPEAK = re.compile(
    r"\b[a-z]+_[a-z_]+: |PREEMPT|ABORTED|SUCCEEDED|-0°|Error: |\bat \S+:\d+")


def west_of_clear(grid_msg: dict, problem: str, cells: int) -> tuple[float, float]:
    """The first cell's centre west of CLEAR (within ``cells``) whose placement problem, as
    the map manager words it, says ``problem``."""
    info = grid_msg["info"]
    res, origin = info["resolution"], info["origin"]["position"]
    ox, oy = origin["x"], origin["y"]
    data = np.asarray(grid_msg["data"], dtype=np.int8).reshape(info["height"], info["width"])
    grid = Grid(ox, oy, res, data)
    col, row = int((CLEAR[0] - ox) // res), int((CLEAR[1] - oy) // res)
    for c in range(col, col - cells, -1):
        x, y = ox + (c + 0.5) * res, oy + (row + 0.5) * res
        if problem in (placement_problem(grid, x, y) or ""):
            return x, y
    raise AssertionError(f"no spot west of CLEAR whose placement is {problem!r}")


def beside_an_obstacle(grid_msg: dict) -> tuple[float, float]:
    """A free cell's centre west of CLEAR, nearer an obstacle than the robot's clearance."""
    return west_of_clear(grid_msg, "from an obstacle", 20)


def names(watcher) -> list[str]:
    return [p["name"] for p in (watcher.latest(POIS) or {"pois": []})["pois"]]


async def test_a_poi_beside_an_obstacle_is_warned_while_placing_and_refused(console: Console,
                                                                            watcher):
    page = console.page
    await watcher.subscribe(POIS, "map_messages/PointsOfInterest")
    await grid_map(watcher)
    beside = beside_an_obstacle(watcher.latest("/map"))
    dialog = page.locator("#poi-dialog")
    name = dialog.locator("input[name=name]")

    await page.click("[data-tool=poi]")
    spot = await console.to_client(*beside)
    await page.mouse.move(*spot)
    hint = page.locator("#hint[data-warning]")
    await hint.wait_for()
    assert "Not a good spot" in await hint.text_content()
    assert "0.25 m" in await hint.text_content()  # the clearance it needs, said
    await page.mouse.click(*spot)
    assert "will refuse" in await dialog.locator("#poi-warning").text_content()
    await name.fill("beside the desk")
    await name.press("Enter")
    refused = page.locator("#log li.error", has_text="nearer than the robot's clearance")
    await refused.wait_for(timeout=10_000)
    assert (await refused.locator(".text").text_content()).startswith("POI: ")  # not "add_poi:"
    assert "beside the desk" not in names(watcher)
    assert await page.locator('#poi-list li[data-name="beside the desk"]').count() == 0
    # the dialog stays open with the refusal and the name as typed (issue 46, friction 8)
    assert await dialog.is_visible()
    assert await name.input_value() == "beside the desk"
    assert "nearer than the robot's clearance" in await dialog.locator("#poi-error").text_content()
    await dialog.get_by_role("button", name="Cancel").click()
    await dialog.wait_for(state="hidden")

    await page.click("[data-tool=poi]")
    spot = await console.to_client(*CLEAR)
    await page.mouse.move(*spot)
    assert await page.locator("#hint[data-warning]").count() == 0
    await page.mouse.click(*spot)
    assert await dialog.locator("#poi-warning").text_content() == ""
    await name.fill("desk")
    await name.press("Enter")
    await page.locator('#poi-list li[data-name="desk"]').wait_for(timeout=10_000)
    await console.frame()
    img = await console.screenshot_array()
    px, py = spot
    patch = img[int(py) - 8:int(py) + 9, int(px) - 8:int(px) + 9]
    assert (np.linalg.norm(patch - np.asarray(POI_COLOUR), axis=2) < 60).any()  # drawn there
    # the refusal is the only error the page reported (log() mirrors it on the console)
    assert [e for e in console.errors if "nearer than the robot's clearance" not in e] == []


async def test_the_console_at_work_in_plain_words(console: Console, watcher):
    """A wall, two POIs and the robot on its way to a goal: the README's screenshot
    (UPDATE_SCREENSHOT=1 writes web/screenshot.png, 1440×900); then cancelled. The Messages
    panel says it all without request names, actionlib's words, stack lines or "-0°"."""
    page = console.page
    await watcher.subscribe(POIS, "map_messages/PointsOfInterest")
    grid = await grid_map(watcher)
    await add_poi(watcher, "kitchen", *grid.nearest_clear(3.0, 13.0))
    await add_poi(watcher, "meeting room", *grid.nearest_clear(20.0, 12.0))
    await watcher.until(lambda: len(names(watcher)) == 2, 10, "two POIs")
    await console.tab("map")
    await page.click("[data-tool=wall]")
    await console.drag(await console.to_client(9.0, 6.8), await console.to_client(9.0, 7.8))
    await page.locator("#line-counts", has_text="1 wall ·").wait_for(timeout=10_000)
    await console.tab("operate")
    await page.click("[data-tool=goal]")
    await page.mouse.click(*(await console.to_client(*grid.nearest_clear(20.0, 8.0))))
    await console.wait_data("#goal-status", "status", "active", timeout=15)
    await page.wait_for_function("() => window.hitrobot.layers.path.points.length > 1 && "
                                 "window.hitrobot.layers.scan.points.length > 0")
    await console.snapshot("screenshot")
    await page.click("#cancel-goal")
    await console.wait_data("#goal-status", "status", "preempted")
    await page.locator("#log li", has_text="goal cancelled").wait_for(timeout=10_000)
    texts = await page.locator("#log li .text").all_text_contents()
    assert [t for t in texts if DEVELOPER_SPEAK.search(t)] == [], texts
    assert "1 wall · 0 tracks" in await page.text_content("#line-counts")
    assert console.errors == []

"""Dialogs and words (issue 34), in a real browser against the simulator: Enter confirms and
Esc cancels in every dialog, the Delete confirmation included; a cancelled goal says
"cancelled", an angle is never "-0°", one wall and one message are singular."""

from __future__ import annotations

from tests.web.conftest import Console, add_poi, grid_map

NODE = "/slamware_ros_sdk_server_node"
POIS = "/map_manager/pois"


def named(watcher, name: str):
    pois = (watcher.latest(POIS) or {}).get("pois", [])
    return next((p for p in pois if p["name"] == name), None)


async def add_wall(watcher, y: float) -> None:
    await watcher.publish(f"{NODE}/add_line", {
        "usage": {"usage": 0}, "line": {"id": 0, "start": {"x": 18.0, "y": y},
                                         "end": {"x": 22.5, "y": y}}},
        "slamware_ros_sdk/AddLineRequest")


async def test_enter_confirms_and_escape_cancels_the_delete_dialog(console: Console, watcher):
    page = console.page
    await watcher.subscribe(POIS, "map_messages/PointsOfInterest")
    confirm = page.locator("#confirm-dialog")
    await add_poi(watcher, "kept", 2.0, 2.0)
    await add_poi(watcher, "gone", 3.0, 2.0)
    kept = page.locator('#poi-list li[data-name="kept"]')
    gone = page.locator('#poi-list li[data-name="gone"]')
    await gone.wait_for(timeout=10_000)

    # Esc cancels: the POI stays
    await kept.locator("button.delete").click()
    await confirm.locator(".question", has_text="Delete the POI “kept”?").wait_for()
    await page.keyboard.press("Escape")
    await confirm.wait_for(state="hidden")
    # a round trip through the server: another client's POI arrives after anything the page sent
    await add_poi(watcher, "marker", 1.0, 1.0)
    await watcher.until(lambda: named(watcher, "marker"), 10, "the marker POI")
    assert named(watcher, "kept")

    # Enter confirms: the POI is deleted (Cancel is the dialog's first button)
    await gone.locator("button.delete").click()
    await confirm.locator(".question", has_text="Delete the POI “gone”?").wait_for()
    await page.keyboard.press("Enter")
    await confirm.wait_for(state="hidden")
    await watcher.until(lambda: not named(watcher, "gone"), 10, "the POI deleted by Enter")
    await gone.wait_for(state="detached")
    await page.locator("#log li", has_text="POI “gone” deleted").wait_for(timeout=10_000)
    assert await kept.count() == 1
    assert console.errors == []


async def test_clear_walls_dialog_keys_and_words(console: Console, watcher):
    page = console.page
    confirm = page.locator("#confirm-dialog")
    question = confirm.locator(".question")
    counts = page.locator("#line-counts")
    await console.tab("map")

    # one wall: "Remove the virtual wall?"; Esc cancels and the wall stays
    await add_wall(watcher, 1.6)
    await page.locator("#line-counts", has_text="1 wall ·").wait_for(timeout=10_000)
    await page.click("#clear-walls")
    await confirm.wait_for()
    assert await question.text_content() == "Remove the virtual wall?"
    await page.keyboard.press("Escape")
    await confirm.wait_for(state="hidden")

    # a second wall arrives after anything the page sent: two walls, so nothing was cleared
    await add_wall(watcher, 2.6)
    await page.locator("#line-counts", has_text="2 walls ·").wait_for(timeout=10_000)
    await page.click("#clear-walls")
    await confirm.wait_for()
    assert await question.text_content() == "Remove all 2 virtual walls?"
    await page.keyboard.press("Enter")
    await confirm.wait_for(state="hidden")
    await page.locator("#line-counts", has_text="0 walls ·").wait_for(timeout=10_000)
    assert "0 walls" in await counts.text_content()
    assert console.errors == []


async def test_cancelled_goal_and_angle_words(console: Console, watcher):
    page = console.page
    await watcher.subscribe(POIS, "map_messages/PointsOfInterest")
    # a POI facing a hair below 0 rad: "0°", not "-0°"
    await watcher.publish("/map_manager/add_poi", {
        "type": 100, "name": "square", "remarks": "",
        "pose": {"position": {"x": 2.0, "y": 2.0, "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": -0.001, "w": 1.0}},
    }, "map_messages/PointOfInterest")
    where = page.locator('#poi-list li[data-name="square"] .poi-where')
    await where.wait_for(timeout=10_000)
    assert (await where.text_content()).endswith("m · 0°"), await where.text_content()

    # a goal the operator cancels ends "cancelled", never "PREEMPTED"
    grid = await grid_map(watcher)
    gx, gy = grid.nearest_clear(20.0, 3.0)
    await page.click("[data-tool=goal]")
    await page.mouse.click(*(await console.to_client(gx, gy)))
    await console.wait_data("#goal-status", "status", "active")
    await page.click("#cancel-goal")
    await console.wait_data("#goal-status", "status", "preempted")
    status = await page.text_content("#goal-status")
    assert status.lower().startswith("cancelled → ") and "PREEMPTED" not in status.upper(), status
    await page.locator("#log li", has_text="goal cancelled").wait_for(timeout=10_000)
    logged = await page.text_content("#log")
    assert "preempted" not in logged.lower() and "-0°" not in logged, logged
    assert console.errors == []


async def test_one_message_is_singular(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/inspector_words", "std_msgs/String")
    await console.tab("inspect")
    await page.click("#topics-refresh")
    await page.fill("#topic-filter", "inspector_words")
    await page.click('#topic-list li[data-topic="/inspector_words"]')
    await page.click("#publish-box summary")
    field = page.locator("#publish-form input[name=data]")
    await field.wait_for()
    await field.fill("one")
    await page.click("#publish-send")
    await page.locator("#topic-last", has_text="one").wait_for()
    await page.wait_for_selector('#topic-rate[data-count="1"]', timeout=5_000)
    rate = await page.text_content("#topic-rate")
    assert rate.endswith("· 1 message"), rate
    assert console.errors == []

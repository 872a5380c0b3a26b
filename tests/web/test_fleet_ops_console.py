"""The fleet-operations console (web/fleetops.js, the Fleet tab) in Chromium against a real server
with two named simulated robots, driving the fleet's real services: a task dispatched from the
form to a chosen robot with the bids shown, paused and resumed from its row, then done in the
History; a robot taken out of service from the console and skipped by a "best" dispatch; a
schedule added, listed and removed; refusals in the service's words; a robot set to 20 % (by
roslibpy, as an app developer's test would) shown going to charge under the policy's
thresholds; and no raw JSON or Python reprs anywhere on the tab."""

from __future__ import annotations

import asyncio
import re

import pytest
import roslibpy
from playwright.async_api import TimeoutError as PlaywrightTimeout

from tests.helpers import Watcher, connect_roslibpy
from tests.web import test_fleet
from tests.web.conftest import Console, add_poi

Y = 8.0  # the office corridor
# what the page must never show: JSON or Python reprs, JavaScript's placeholders
RAW = re.compile(r"[{}\[\]]|\bNone\b|\bTrue\b|\bFalse\b|undefined|NaN|\[object|"
                 r"\b[a-z]+_[a-z_]+: |Error: ")


fleet_console = test_fleet.fleet_console  # a and b idle on the map, the page ready


@pytest.fixture
async def ops(fleet_console: Console):
    """The console of a two-robot server, its Fleet tab shown once the policy is read."""
    page = fleet_console.page
    await page.wait_for_function("() => Boolean(window.hitrobot.fleetops.policy)")
    await page.click(".tabs [data-tab=fleet]")
    await page.locator("#fleetops-robots-panel").wait_for(state="visible")
    return fleet_console


async def plain_words(page) -> None:
    text = await page.inner_text("#fleetops")
    assert not RAW.search(text), RAW.search(text)


async def idle(page, robot: str) -> None:
    """Wait until the console lists ``robot`` idle (on a busy machine a robot's reports may
    come late, and the fleet calls it offline meanwhile)."""
    await page.locator(f"#fleetops-robots li[data-robot={robot}][data-state=idle]").wait_for(
        timeout=30_000)


async def wait_state(page, list_id: str, task: str, state: str, timeout: float = 15) -> None:
    """Wait until task ``task``'s row in ``list_id`` shows ``state`` (the row's text if not)."""
    try:
        await page.wait_for_function(
            "([list, task, state]) => { const row = document.querySelector("
            "`#${list} li[data-task='${task}']`); return row && row.dataset.state === state; }",
            arg=[list_id, task, state], timeout=timeout * 1000)
    except PlaywrightTimeout:
        row = page.locator(f"#{list_id} li[data-task='{task}']")
        shown = await row.inner_text() if await row.count() else "no such row"
        raise AssertionError(f"task {task} never {state}: {shown}") from None


async def replied(page, timeout: float = 30) -> tuple[str, str]:
    """The form's next reply (accepted, robot): the reply box is emptied, then filled."""
    await page.wait_for_function(
        "() => document.querySelector('#fleetops-reply').dataset.accepted !== undefined",
        timeout=timeout * 1000)
    box = page.locator("#fleetops-reply")
    return await box.get_attribute("data-accepted"), await box.get_attribute("data-robot")


async def test_dispatch_to_a_chosen_robot_pause_resume_and_history(ops: Console):
    """a is taken out of service first, so the task asked of it waits (deterministically, however
    slow the machine) while it is paused and resumed; back in service, a runs it."""
    page = ops.page
    assert await page.locator(".tabs [data-tab=fleet]").is_visible()
    w = await Watcher.open(ops.server.port)
    try:
        await add_poi(w, "east", 8.0, Y)  # 4 m from a and from b
    finally:
        await w.close()
    a = page.locator("#fleetops-robots li[data-robot=a]")
    await a.locator("[data-action=service]").click()
    await page.locator("#fleetops-robots li[data-robot=a][data-service=out]").wait_for()
    await page.locator("#fleetops-poi option[value=east]").wait_for(state="attached")
    await page.select_option("#fleetops-poi", "east")
    await page.select_option("#fleetops-robot", "a")
    await idle(page, "a")
    await page.fill("#fleetops-priority", "5")
    await page.click("#fleetops-dispatch")
    assert await replied(page) == ("true", ""), await page.inner_text("#fleetops-reply")
    task = await page.get_attribute("#fleetops-reply", "data-id")
    assert "queued for a" in await page.inner_text("#fleetops-reply .headline")
    assert "Why a" in await page.inner_text("#fleetops-reply")
    assert [b.split(" ")[0] for b in await page.locator("#fleetops-reply .bids li")
            .all_inner_texts()] == ["a"]  # a named robot: its bid only

    await wait_state(page, "fleetops-tasks", task, "queued")
    row = page.locator(f"#fleetops-tasks li[data-task='{task}']")
    text = await row.inner_text()
    assert "Go to" in text and "east" in text and "waiting" in text, text
    assert "a (asked for) · priority 5" in text and "started –" in text, text
    assert "queued for a" in text, text  # why it waits
    await row.locator("[data-action=pause]").click()
    await wait_state(page, "fleetops-tasks", task, "paused")
    assert await row.locator("[data-action=resume]").is_enabled()
    assert await row.locator("[data-action=pause]").count() == 0
    await row.locator("[data-action=resume]").click()
    await wait_state(page, "fleetops-tasks", task, "queued")
    await a.locator("[data-action=service]").click()  # back in service: a takes it
    await wait_state(page, "fleetops-tasks", task, "succeeded", timeout=40)
    text = await row.inner_text()
    assert await row.get_attribute("data-robot") == "a" and "a arrived" in text, text
    assert re.search(r"started \d\d:\d\d:\d\d · finished \d\d:\d\d:\d\d", text), text
    assert await row.locator("button").count() == 0  # nothing to pause or cancel once done

    await page.click("#fleetops-tasks-panel [data-view=history]")
    await wait_state(page, "fleetops-history", task, "succeeded")
    first = page.locator("#fleetops-history li").first
    assert await first.get_attribute("data-task") == task  # newest first
    assert await first.get_attribute("data-robot") == "a"
    await page.select_option("#fleetops-history-robot", "b")
    await page.locator("#fleetops-history li.empty", has_text="nothing finished yet").wait_for()
    await plain_words(page)
    assert ops.errors == []


async def set_battery(port: int, robot: str, percent: float) -> dict:
    """/NAME/sim/set_battery from roslibpy (its own thread: the server runs on this loop)."""
    def call() -> dict:
        ros = connect_roslibpy(port)
        try:
            service = roslibpy.Service(ros, f"/{robot}/sim/set_battery",
                                       "hitrobot_msgs/SimSetBattery")
            return dict(service.call(roslibpy.ServiceRequest({"percent": percent}), timeout=10))
        finally:
            ros.close()
    return await asyncio.to_thread(call)


async def test_service_schedules_refusals_and_charging(ops: Console):
    page = ops.page
    policy = await page.inner_text("#fleetops-policy")
    assert "under 25 %" in policy and "until 90 %" in policy, policy
    assert "Times are the site's" in await page.inner_text("#fleetops-zone")

    a = page.locator("#fleetops-robots li[data-robot=a]")
    await a.locator("[data-action=service]").click()
    await page.locator("#fleetops-robots li[data-robot=a][data-service=out]").wait_for()
    assert "out of service" in await a.inner_text()
    assert await a.locator("[data-action=service]").inner_text() == "Put back in service"
    w = await Watcher.open(ops.server.port)
    try:
        await add_poi(w, "near_a", 5.0, Y)
    finally:
        await w.close()
    await page.locator("#fleetops-poi option[value=near_a]").wait_for(state="attached")
    await page.select_option("#fleetops-poi", "near_a")
    await idle(page, "b")
    await page.click("#fleetops-dispatch")  # the best robot: a is out, so b
    assert await replied(page) == ("true", "b"), await page.inner_text("#fleetops-reply")
    bids = await page.locator("#fleetops-reply .bids li").all_inner_texts()
    assert [b.split(" ")[0] for b in bids] == ["b", "a:"], bids  # a skipped, and why:
    assert bids[1] == "a: skipped, out of service", bids
    await a.locator("[data-action=service]").click()
    await page.locator("#fleetops-robots li[data-robot=a][data-service=in]").wait_for()

    # schedules: refused in the service's words, added, listed, removed
    await page.fill("#fleetops-when", "every 2 s")
    await page.click("#fleetops-schedule")
    assert (await replied(page))[0] == "false"
    assert await page.inner_text("#fleetops-reply .headline") == \
        "Refused: when: every must be at least 10 s"
    await page.fill("#fleetops-when", "every 2 h")
    await page.click("#fleetops-schedule")
    assert (await replied(page))[0] == "true", await page.inner_text("#fleetops-reply")
    listed = page.locator("#fleetops-schedules li[data-schedule]")
    await listed.wait_for()
    text = await listed.inner_text()
    assert "every 2 h" in text and "near_a" in text and "the best robot" in text, text
    # today's time with seconds, or another day's date and time (late in the day, "every 2 h"
    # next fires tomorrow)
    assert re.search(r"next (\d\d:\d\d:\d\d|\d{1,2} \w+ \d\d:\d\d)", text), text
    await listed.locator("[data-action=remove]").click()
    await page.locator("#fleetops-schedules li.empty", has_text="no schedules").wait_for()

    # a point off the map: refused in the service's words
    await page.select_option("#fleetops-poi", "")
    await page.fill("#fleetops-x", "-0.4")
    await page.fill("#fleetops-y", "-0.4")
    await page.click("#fleetops-dispatch")
    assert (await replied(page))[0] == "false"
    assert await page.inner_text("#fleetops-reply .headline") == \
        "Refused: (-0.4, -0.4) is off the map"

    # a at 20 %: the policy sends it to its dock, and the console says so
    got = await set_battery(ops.server.port, "a", 20.0)
    assert got["success"], got
    going = page.locator("#fleetops-robots li[data-robot=a][data-charge=going]",
                         has_text=re.compile(r"\b(19|20) %"))  # its battery shown as it is
    await going.wait_for(timeout=10_000)
    assert "going to charge" in await going.inner_text()
    charge = page.locator("#fleetops-tasks li[data-state=running]", has_text="Charge")
    assert "its dock" in await charge.inner_text()
    await plain_words(page)
    await ops.snapshot("console-fleet-ops")
    assert ops.errors == []


async def test_the_fleets_words(ops: Console):
    """Issue 46, friction 7, as the operator reads it: the form's point starts where a robot
    stands (not (0, 0), inside the outer wall), "the best robot" is one phrase on both tabs, a
    robot's row says what it does in words, the bids name the robot skipped and why, a pause
    says what happened, a robot waiting for a zone says so, and the reply "task N: a is on its
    way" is replaced once task N failed."""
    page = ops.page
    await idle(page, "a")
    await page.select_option("#fleetops-poi", "")
    assert (await page.input_value("#fleetops-x"), await page.input_value("#fleetops-y")) == (
        "4.0", "8.0")  # where a stands
    best = await page.text_content("#fleetops-robot option[value='']")
    assert best == await page.text_content("#fleet-send option[value='']") == \
        "the best robot (by cost)"

    b = page.locator("#fleetops-robots li[data-robot=b]")
    await b.locator("[data-action=service]").click()
    await page.locator("#fleetops-robots li[data-robot=b][data-service=out]").wait_for()
    await page.fill("#fleetops-x", "9.0")
    await page.click("#fleetops-dispatch")
    assert await replied(page) == ("true", "a"), await page.inner_text("#fleetops-reply")
    bids = await page.locator("#fleetops-reply .bids li").all_inner_texts()
    assert bids[1:] == ["b: skipped, out of service"], bids
    task = await page.get_attribute("#fleetops-reply", "data-id")
    moving = page.locator("#fleetops-robots li[data-robot=a][data-state=moving]")
    await moving.wait_for(timeout=10_000)
    assert "go to" in await moving.inner_text() and "Action" not in await moving.inner_text()

    row = page.locator(f"#fleetops-tasks li[data-task='{task}']")
    await row.locator("[data-action=pause]").click()
    await wait_state(page, "fleetops-tasks", task, "paused")
    text = await row.inner_text()
    assert "paused on its way: a stopped" in text and "(running)" not in text, text
    await row.locator("[data-action=cancel]").click()
    await wait_state(page, "fleetops-tasks", task, "cancelled")
    headline = await page.inner_text("#fleetops-reply .headline")
    assert headline == f"task {task} cancelled", headline

    await page.select_option("#fleetops-robot", "a")
    await page.fill("#fleetops-x", "10.5")
    await page.click("#fleetops-dispatch")
    assert (await replied(page))[0] == "true", await page.inner_text("#fleetops-reply")
    failing = await page.get_attribute("#fleetops-reply", "data-id")
    said = await page.inner_text("#fleetops-reply .headline")  # on its way, or queued for a
    assert said.startswith(f"task {failing}: ") and " a " in f"{said} ", said
    await wait_state(page, "fleetops-tasks", failing, "running")
    await moving.wait_for(timeout=10_000)
    w = await Watcher.open(ops.server.port)
    try:
        assert (await w.call("/a/sit_down"))["values"]["success"]
    finally:
        await w.close()
    await wait_state(page, "fleetops-tasks", failing, "failed")
    await page.wait_for_function(
        "(id) => document.querySelector('#fleetops-reply .headline').textContent"
        ".startsWith(`task ${id} failed: a failed`)", arg=failing, timeout=5_000)

    # a robot stopped before a mutex zone: listed as waiting for it (the renderer fed the live
    # list with the state the fleet gives such a robot)
    shown = await page.evaluate("""() => {
        const ops = window.hitrobot.fleetops;
        ops.onRobots(ops.robots.map((r) => (r.name === 'a' ? { ...r, state: 'waiting',
            message: 'waiting for zone lobby (held by b)' } : r)));
        return document.querySelector('#fleetops-robots li[data-robot=a]').innerText;
    }""")
    assert "waiting for zone lobby (held by b)" in shown and "idle" not in shown, shown
    await plain_words(page)
    assert ops.errors == []

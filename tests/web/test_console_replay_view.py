"""The console on ``hitrobot-server replay`` says one thing: "Replaying NAME — playing t / T" in
its hint, robot pill and goal status, never "No robot" beside a recorded "robot connected", and
the map is not dimmed as a robot's absence dims it."""

from __future__ import annotations

from tests.helpers import ServerProcess
from tests.web.test_console_recordings import synthetic_recording

BAR = "#replay-bar"
CONNECTED = {"level": 0, "name": "/Robot/Connection", "message": "robot connected",
             "hardware_id": "", "values": []}


async def test_the_replay_view_says_one_thing_and_keeps_the_map_bright(browser, tmp_path):
    path = tmp_path / "shift.mcap"
    await synthetic_recording(path, diagnostics=CONNECTED)  # "robot connected" in it
    server = ServerProcess("--loop", command=("replay", str(path)))
    try:
        page = browser.pages[0] if browser.pages else await browser.new_page()
        await page.goto(f"http://127.0.0.1:{server.port}/")
        await page.wait_for_selector(f"{BAR}[data-paused=false]", timeout=20_000)
        # the robot presence poll (every 2 s) has answered "no robot" by then
        await page.wait_for_function("() => document.body.classList.contains('no-robot')",
                                     timeout=10_000)
        await page.wait_for_function(
            "() => document.getElementById('hint').textContent.includes('— playing')",
            timeout=10_000)
        hint = await page.locator("#hint").inner_text()
        assert hint.startswith("Replaying shift.mcap — playing ") and "/ 0:10.0" in hint, hint
        assert await page.locator("#robot-state .value").inner_text() == "replaying shift.mcap"
        assert await page.locator("#goal-status").inner_text() == "Replaying shift.mcap"
        text = await page.locator("body").inner_text()
        assert "No robot" not in text and "robot connected" not in text, text
        filters = await page.eval_on_selector_all(
            ".map canvas", "cs => cs.map((c) => getComputedStyle(c).filter)")
        assert filters and set(filters) == {"none"}, filters

        await page.click(f"{BAR} .play")
        await page.wait_for_function(
            "() => document.getElementById('hint').textContent.includes('— paused')",
            timeout=10_000)
        assert "No robot" not in await page.locator("body").inner_text()
    finally:
        server.stop()

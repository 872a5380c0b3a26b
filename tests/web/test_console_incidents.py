"""The console's incidents (web/recordings.js) in Chromium: a server with a black box sees the
robot's emergency stop pressed (the simulator's ``/sim/emergency_stop``, reported by the robot's
health on /diagnostics: an incident comes from the robot, never from what a client publishes);
the Recordings panel lists the file it left with its cause, and two clicks (Replay, Open
replay) open that file's replay in a tab of its own."""

from __future__ import annotations

import re

from tests.helpers import WsClient
from tests.web.conftest import ARTIFACTS

ROW = "#incident-list li[data-cause=emergency_stop]"


async def test_an_incident_is_listed_with_its_cause_and_replays_in_two_clicks(
        browser, make_server, tmp_path):
    folder = tmp_path / "recordings"
    server = await make_server(robot="sim", black_box=30.0, record_dir=str(folder))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.click(".tabs [data-tab=status]")
    await page.wait_for_selector("#incidents:not([hidden]) #incident-list li.empty",
                                 timeout=20_000)  # the server keeps a black box, no incident

    client = await WsClient.open(server.port)
    try:
        reply = await client.call("/sim/emergency_stop", {"data": True})
        assert reply["result"] and reply["values"]["success"], reply
        row = page.locator(ROW)
        await row.wait_for(timeout=20_000)
        assert await row.locator(".cause").inner_text() == "Emergency stop"
        when = await row.locator(".when").inner_text()  # 24-hour time, as the rest (issue 46)
        assert re.search(r"\b\d\d:\d\d:\d\d$", when) and not re.search(r"AM|PM", when), when
        assert "emergency stop" in (await row.locator(".detail").inner_text()).lower()
        name = await row.get_attribute("data-name")
        assert name.startswith("blackbox-") and name.endswith("-emergency_stop.mcap")
        assert (folder / name).is_file()
        # the recordings list shows the file too, with its download link
        await page.locator(f'#recording-list li[data-name="{name}"] a').wait_for(timeout=10_000)
        log = page.locator("#log li[data-level=warning]", has_text="Emergency stop")
        await log.first.wait_for(timeout=10_000)

        await row.locator("button.replay").click()  # click 1
        opener = row.locator("a.open-replay")
        await opener.wait_for(timeout=40_000)  # a replay server starting
        async with browser.expect_page(timeout=20_000) as new_page:
            await opener.click()  # click 2
        replay = await new_page.value
        await replay.wait_for_selector("#replay-bar:not([hidden])", timeout=30_000)
        assert name in await replay.locator("#replay-bar .file").inner_text()
        ARTIFACTS.mkdir(exist_ok=True)
        await page.screenshot(path=str(ARTIFACTS / "console-incidents.png"))
    finally:
        await client.close()

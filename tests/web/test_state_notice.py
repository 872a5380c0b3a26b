"""The console says once where the robot's state came from, and while the state cannot be
saved (web/statenotice.js)."""

from __future__ import annotations

import re

from tests.helpers import Watcher
from tests.nodes.map_manager.util import MM, poi, request
from tests.state.failing_folder import FailingFolder
from tests.web.conftest import READY

NOTICE = "#log li.info .text"


async def notices(page) -> list[str]:
    return [t for t in await page.locator(NOTICE).all_text_contents()
            if t.startswith(("state restored from", "started fresh in"))]


async def test_the_console_says_started_fresh_then_restored_once(make_server, browser,
                                                                  tmp_path):
    state = tmp_path / "state"
    page = browser.pages[0] if browser.pages else await browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))

    async def console_of_a_server(notice: str):
        """A server on the test's state folder, and the page on it once it says ``notice``."""
        server = await make_server(robot="sim", sim_speed=4, map_dir=str(tmp_path / "maps"),
                                   state_dir=str(state))
        await page.goto(f"http://127.0.0.1:{server.port}/")
        await page.wait_for_function(READY, timeout=30_000)
        await page.wait_for_function(
            "(notice) => [...document.querySelectorAll('#log li.info .text')]"
            ".some(e => e.textContent.startsWith(notice))", arg=notice, timeout=10_000)
        return server

    first = await console_of_a_server("started fresh in")
    w = await Watcher.open(first.port)
    await w.client.send({"op": "set_level", "level": "info"})
    assert (await request(w, f"{MM}/add_poi", "map_messages/PointOfInterest",
                          poi("kitchen", 3.0, 8.0), "p1"))["level"] == "info"
    for op in ("save_map", "load_map"):  # the loaded map's marker survives the restart too
        assert (await request(w, f"{MM}/{op}", "map_messages/SaveMap",
                              {"filename": "office_v1"}, op))["level"] == "info"
    await w.close()
    await first.stop()

    second = await console_of_a_server("state restored from")
    # once: further /diagnostics_agg messages (1 Hz) add nothing
    w = await Watcher.open(second.port)
    await w.subscribe("/diagnostics_agg")
    for _ in range(2):
        await w.next("/diagnostics_agg")
    await w.close()
    got = await notices(page)
    assert len(got) == 1 and "1 POIs" in got[0] and str(state / "sim-office") in got[0], got
    # the values of then are not quoted beside the live ones (issue 46: "battery 78 %" beside a
    # bar at 77 %)
    assert "at the server's start" in got[0] and not re.search(r"battery \d", got[0]), got
    await page.click(".tabs [data-tab=map]")
    await page.locator("#map-list li[data-name=office_v1] small", has_text="· loaded").wait_for(
        timeout=10_000)
    assert errors == []


async def test_the_console_says_while_the_state_is_not_being_saved(make_server, browser,
                                                                   tmp_path):
    """A full state disk (issue 36): a red pill "state is not being saved: disk full" for as
    long as it lasts, gone once a write succeeds again."""
    folder = FailingFolder(tmp_path / "state")
    try:
        page = browser.pages[0] if browser.pages else await browser.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
        server = await make_server(robot="sim", sim_speed=4, map_dir=str(tmp_path / "maps"),
                                   state_dir=str(folder.root))
        await page.goto(f"http://127.0.0.1:{server.port}/")
        await page.wait_for_function(READY, timeout=30_000)
        pill = page.locator("#state-saving")
        assert await pill.is_hidden()
        w = await Watcher.open(server.port)
        await w.client.send({"op": "set_level", "level": "info"})
        folder.fail(folder.root / "sim-office")
        refused = await request(w, f"{MM}/add_poi", "map_messages/PointOfInterest",
                                poi("while_full", 3.0, 8.0, remarks="x" * 6000), "p1")
        assert refused["level"] == "error"
        text = f"state is not being saved: {folder.reason}"
        await pill.get_by_text(text).wait_for(state="visible", timeout=10_000)
        assert await page.locator("#log li.error .text", has_text=text).count() >= 1
        folder.free()
        assert (await request(w, f"{MM}/add_poi", "map_messages/PointOfInterest",
                              poi("after", 3.0, 8.0), "p2"))["level"] == "info"
        await pill.wait_for(state="hidden", timeout=10_000)
        await w.close()
        await server.stop()
        assert errors == []
    finally:
        folder.close()

"""The console's record and replay controls (web/recordings.js) in Chromium: the replay timeline
(play/pause, seek, speed) against ``hitrobot-server replay``, and the Recordings panel (start,
stop, list, download) against a server."""

from __future__ import annotations

import time

from hitrobot_server.bus.core import Bus
from hitrobot_server.record.recorder import Recorder
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import ServerProcess, Watcher
from tests.web.conftest import ARTIFACTS

BAR = "#replay-bar"


async def synthetic_recording(path, diagnostics: dict | None = None) -> None:
    """10 s of a robot pose at 10 Hz and a latched map, stamped as if recorded live; and
    ``diagnostics`` (a /diagnostics_agg status) at 2 Hz when given."""
    bus = Bus(TypeRegistry.default())
    bus.advertise("/map", "nav_msgs/OccupancyGrid", "t", "/t", latch=True)
    bus.advertise("/robot_pose", "geometry_msgs/Pose", "t", "/t")
    bus.advertise("/diagnostics_agg", "diagnostic_msgs/DiagnosticArray", "t", "/t")
    t0 = time.time()
    bus.publish("/map", {"header": {"frame_id": "map"},
                         "info": {"resolution": 0.05, "width": 200, "height": 100,
                                  "origin": {"orientation": {"w": 1.0}}},
                         "data": [0] * 20000}, stamp=t0)
    recorder = Recorder(bus, path)
    recorder.start()
    for i in range(101):
        bus.publish("/robot_pose", {"position": {"x": 1 + i * 0.05, "y": 2.5},
                                    "orientation": {"w": 1.0}}, stamp=t0 + i * 0.1)
        if diagnostics is not None and i % 5 == 0:
            bus.publish("/diagnostics_agg", {"status": [diagnostics]}, stamp=t0 + i * 0.1)
    await recorder.stop()


async def test_the_replay_timeline_plays_pauses_seeks_and_sets_the_speed(browser, tmp_path):
    path = tmp_path / "synthetic.mcap"
    await synthetic_recording(path)
    server = ServerProcess("--loop", command=("replay", str(path)))
    watcher = None
    try:
        watcher = await Watcher.open(server.port)
        await watcher.client.send({"op": "subscribe", "topic": "/replay/state"})
        page = browser.pages[0] if browser.pages else await browser.new_page()
        await page.goto(f"http://127.0.0.1:{server.port}/")
        await page.wait_for_selector(f"{BAR}[data-paused=false]", timeout=20_000)
        assert "synthetic.mcap" in await page.locator(f"{BAR} .file").inner_text()
        assert "/ 0:10.0" in await page.locator(f"{BAR} .time").inner_text()

        await page.click(f"{BAR} .play")
        await page.wait_for_selector(f"{BAR}[data-paused=true]", timeout=10_000)
        await page.locator(f"{BAR} .seek").fill("5")
        await page.wait_for_selector(f'{BAR}[data-position="5.000"]', timeout=10_000)
        assert "0:05.0 / 0:10.0" in await page.locator(f"{BAR} .time").inner_text()
        await page.select_option(f"{BAR} .speed", "2")
        await page.wait_for_selector(f'{BAR}[data-speed="2"]', timeout=10_000)
        await watcher.until(lambda: (s := watcher.latest("/replay/state")) is not None
                            and s["speed"] == 2.0 and s["paused"] and s["position"] == 5.0,
                            10, "the server paused at 5 s, speed 2")
        await page.click(f"{BAR} .play")
        await page.wait_for_selector(f"{BAR}[data-paused=false]", timeout=10_000)
        await watcher.until(lambda: (s := watcher.latest("/replay/state")) is not None
                            and not s["paused"] and s["position"] > 5.0, 10, "playing again")
        ARTIFACTS.mkdir(exist_ok=True)
        await page.screenshot(path=str(ARTIFACTS / "console-replay-timeline.png"))
    finally:
        if watcher is not None:
            await watcher.close()
        server.stop()


async def test_the_recordings_panel_starts_stops_lists_and_downloads(browser, make_server,
                                                                      tmp_path):
    folder = tmp_path / "recordings"
    server = await make_server(record_dir=str(folder))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.click(".tabs [data-tab=status]")
    await page.wait_for_selector("#record-state[data-recording=false]", timeout=20_000)
    await page.wait_for_selector("#recording-list li.empty", timeout=10_000)
    # --robot none: the console says "no robot" and disables robot actions, not recording
    await page.wait_for_selector("body.no-robot", timeout=10_000)
    assert not await page.is_disabled("#record-start")

    await page.click("#record-start")
    await page.wait_for_selector("#record-state[data-recording=true]", timeout=10_000)
    assert await page.is_disabled("#record-start")
    await page.wait_for_function(
        "() => /[1-9]\\d* messages/.test(document.getElementById('record-state').textContent)",
        timeout=10_000)  # it grows: /record/state itself is recorded every second
    await page.click("#record-stop")
    await page.wait_for_selector("#record-state[data-recording=false]", timeout=10_000)
    link = page.locator("#recording-list a")
    await link.wait_for(timeout=10_000)
    name = await link.inner_text()
    assert (folder / name).is_file()
    got = await page.evaluate("""async (href) => {
        const r = await fetch(href);
        const bytes = new Uint8Array(await r.arrayBuffer());
        return { status: r.status, size: bytes.length, magic: Array.from(bytes.slice(0, 5)) };
    }""", await link.get_attribute("href"))
    assert got["status"] == 200 and got["size"] == (folder / name).stat().st_size
    assert bytes(got["magic"]) == b"\x89MCAP"

"""The console's mutex zones in Chromium against a server with two named simulated robots: a
zone added over the service is drawn (its outline's pixels, its label and list text), is
filled and says who holds it while a robot stands in it and who waits for it, and a zone drawn
on the map by clicks is saved to the server and removed again."""

from __future__ import annotations

import numpy as np

from tests.helpers import Watcher
from tests.web import test_fleet
from tests.web.conftest import Console

Y = 8.0
ZONE = (0x7B, 0x1F, 0xA2)  # zones.js ZONE_COLOR
HELD = (0xD5, 0x00, 0x00)  # zones.js HELD_COLOR


def polygon(points) -> dict:
    return {"points": [{"x": x, "y": y, "z": 0.0} for x, y in points]}


zones_console = test_fleet.fleet_console  # a and b idle on the map, the page ready


async def colour_near(c: Console, x: float, y: float, colour, radius: int = 3) -> bool:
    await c.frame()
    img = await c.screenshot_array()
    px, py = await c.to_client(x, y)
    patch = img[int(py) - radius:int(py) + radius + 1, int(px) - radius:int(px) + radius + 1]
    return bool((np.linalg.norm(patch - np.asarray(colour), axis=2) < 50).any())


async def test_zones_drawn_held_and_drawn_by_clicks(zones_console: Console):
    c, page = zones_console, zones_console.page
    w = await Watcher.open(c.server.port)
    try:
        # a free zone away from the robots: its outline, its label, its line in the list
        free = [(7.0, 7.2), (9.0, 7.2), (9.0, 8.8), (7.0, 8.8)]
        added = await w.call("/fleet/zone_add", {"name": "corridor_a", "kind": "corridor",
                                                 "polygon": polygon(free)}, timeout=30)
        assert added["values"]["success"], added
        await page.wait_for_selector("#zones-list li[data-zone=corridor_a]")
        assert await page.locator("#zones-panel").is_visible()
        text = await page.text_content("#zones-list li[data-zone=corridor_a]")
        assert "corridor_a (corridor) — free" in text
        assert await colour_near(c, 8.0, 7.2, ZONE)  # the bottom edge's middle
        assert not await colour_near(c, 8.0, 8.0, ZONE, 2)  # not filled while free
        # a zone drawn over robot b: b stands in it, so it holds it
        over_b = [(11.0, 7.2), (13.0, 7.2), (13.0, 8.8), (11.0, 8.8)]
        second = await w.call("/fleet/zone_add", {"name": "door_b", "kind": "door",
                                                  "polygon": polygon(over_b)}, timeout=30)
        assert second["values"]["success"], second
        await page.wait_for_selector("#zones-list li[data-zone=door_b][data-held=yes]")
        held = await page.text_content("#zones-list li[data-zone=door_b]")
        assert "door_b (door) — held by b" in held
        assert await colour_near(c, 12.0, 7.2, HELD)
        # a sent past b waits before the zone, and the list says so
        sent = await w.call("/fleet/dispatch", {"poi": "", "robot": "a", "pose": {
            "position": {"x": 15.0, "y": Y, "z": 0.0},
            "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}}, timeout=15)
        assert sent["values"]["accepted"], sent
        await page.wait_for_function("""() => document.querySelector(
            '#zones-list li[data-zone=door_b]').textContent.includes('waiting: a')""",
                                     timeout=30_000)
        # drawn by clicks: four corners, a name, Save
        await page.click("#zone-draw")
        for x, y in ((15.0, 7.3), (16.0, 7.3), (16.0, 8.7), (15.0, 8.7)):
            px, py = await c.to_client(x, y)
            await page.mouse.click(px, py)
        await page.fill("#zone-name", "drawn")
        await page.fill("#zone-kind", "door")
        await page.click("#zone-save")
        await page.wait_for_selector("#zones-list li[data-zone=drawn]")
        assert "added" in await page.text_content("#zones-reply")
        listed = (await w.call("/fleet/zone_list"))["values"]["zones"]
        drawn = next(z for z in listed if z["name"] == "drawn")
        corners = [(p["x"], p["y"]) for p in drawn["polygon"]["points"]]
        assert len(corners) == 4 and abs(corners[0][0] - 15.0) < 0.1 \
            and abs(corners[2][1] - 8.7) < 0.1, corners
        assert await colour_near(c, 15.5, 7.3, ZONE)
        # a bad one is refused with the field named; Remove takes one away
        await page.click("#zone-draw")
        await page.fill("#zone-name", "no corners")
        await page.click("#zone-save")
        await page.wait_for_function(
            "() => document.querySelector('#zones-reply').textContent.startsWith('name:')")
        await page.click("#zone-cancel")
        await page.click("button[data-remove-zone=drawn]")
        await page.wait_for_function(
            "() => !document.querySelector('#zones-list li[data-zone=drawn]')")
        names = [z["name"] for z in (await w.call("/fleet/zone_list"))["values"]["zones"]]
        assert names == ["corridor_a", "door_b"]
        assert not await colour_near(c, 15.5, 7.3, ZONE)
    finally:
        await w.close()
    assert not c.errors, c.errors

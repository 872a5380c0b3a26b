"""The console opens one subscription per resource (issue 51, item 5): with every panel open (a
fleet server with two robots, every tab visited, the fleet's history shown), each topic the page
reads has exactly one live subscription on the page's connection, however many panels show it
(the robots, the tasks, the POIs were subscribed two or three times each before web/stores.js).

The count is taken on the wire: every `subscribe` and `unsubscribe` frame the browser sent to
the server, as Chromium's network layer saw it (not the page's own code). The server merges one
client's subscriptions to a topic into one bus subscriber, so /rosapi/subscribers cannot tell
them apart; the frames can."""

from __future__ import annotations

import json
from collections import Counter

import pytest

from hitrobot_server.robot.options import RobotEntry
from tests.web.conftest import Console

# what the panels share: each was read by more than one panel, or by one per robot
SHARED = ("/fleet/robots", "/fleet/tasks", "/fleet/zones", "/map_manager/pois",
          "/map_manager/loaded_map", "/diagnostics_agg", "/vda5050/link", "/alpha/drive_lease")


class Subscriptions:
    """The live subscriptions of the page's connections, from the frames it sent."""

    def __init__(self) -> None:
        self.live: dict[str, str] = {}  # subscribe id → topic
        self.sent = 0  # frames seen

    def on_frame(self, payload) -> None:
        self.sent += 1
        if not isinstance(payload, str):
            return
        try:
            op = json.loads(payload)
        except ValueError:
            return
        if not isinstance(op, dict):
            return
        if op.get("op") == "subscribe":
            self.live[op["id"]] = op["topic"]
        elif op.get("op") == "unsubscribe":
            if op.get("id") in self.live:
                del self.live[op["id"]]
            else:  # no id: every subscription of the topic
                self.live = {i: t for i, t in self.live.items() if t != op["topic"]}

    def per_topic(self) -> Counter:
        return Counter(self.live.values())


@pytest.fixture
async def every_panel(make_server, browser, tmp_path):
    server = await make_server(
        robots=(RobotEntry("alpha", "sim"), RobotEntry("beta", "sim", (12.0, 8.0, 3.14))),
        map_dir=str(tmp_path / "maps"))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    subs = Subscriptions()
    page.on("websocket", lambda ws: ws.on("framesent", subs.on_frame))
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.wait_for_function("""() => {
        const h = window.hitrobot;
        return Boolean(h && h.view.mapBounds && h.ros.isConnected && h.fleet.robots.length === 2
            && h.fleet.selected === 'alpha');
    }""", timeout=30_000)
    yield Console(page, server, errors), subs


async def round_trip(page) -> None:
    """Every op the page sent before has reached the server: a service call answered after."""
    await page.evaluate("""() => new Promise((resolve, reject) => {
        const s = new ROSLIB.Service({ ros: window.hitrobot.ros, name: '/rosapi/topics',
                                       serviceType: 'rosapi/Topics' });
        s.callService(new ROSLIB.ServiceRequest({}), resolve, reject);
    })""")


async def test_one_subscription_per_resource_with_every_panel_open(every_panel):
    c, subs = every_panel
    page = c.page
    await page.locator("#fleet-tab").wait_for(state="visible")
    for tab in ("operate", "map", "status", "inspect", "fleet"):
        await c.tab(tab)
        await round_trip(page)
    await page.click("#fleetops-tasks-panel [data-view=history]")  # the history panel too
    await c.tab("operate")
    await page.wait_for_function("() => window.hitrobot.fleetops.robots.length === 2")
    await round_trip(page)

    counts = subs.per_topic()
    assert subs.sent > 0
    for topic in SHARED:
        assert counts[topic] == 1, f"{topic}: {counts[topic]} subscriptions\n{counts}"
    twice = {topic: n for topic, n in counts.items() if n > 1}
    assert twice == {}, f"subscribed more than once: {twice}"
    assert c.errors == []

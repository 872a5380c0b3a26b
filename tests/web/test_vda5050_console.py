"""The robot's VDA 5050 link on the console's Fleet tab (web/vda5050.js), in Chromium against a
real server with a simulated robot linked to a real broker (mosquitto): the broker and topic
tree, connected, the master's current order, and its last error, as a master control sends
them over MQTT."""

from __future__ import annotations

import pytest

from tests.vda5050.conftest import Broker
from tests.vda5050.master import Master, node


@pytest.fixture
def mqtt_broker(tmp_path):
    b = Broker(tmp_path)
    yield b
    b.stop()


async def test_the_fleet_tab_shows_the_vda_5050_link(make_server, browser, mqtt_broker):
    server = await make_server(robot="sim", vda5050=mqtt_broker.url)
    page = browser.pages[0] if browser.pages else await browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.wait_for_function(
        "() => window.hitrobot && window.hitrobot.vda5050 && "
        "window.hitrobot.vda5050.links.some((l) => l.connected)", timeout=30_000)
    await page.click(".tabs [data-tab=fleet]")
    line = page.locator("#vda5050-links li[data-serial=robot]")
    await line.wait_for(state="visible")
    text = await line.inner_text()
    assert f"connected to {mqtt_broker.url} as uagv/v2/hitrobot/robot" in text, text
    assert "no order" in text

    async with Master(mqtt_broker.port) as master:
        here = (await master.sync())["agvPosition"]
        await master.order("console-1", 0, [node("a", 0, here["x"], here["y"]),
                                            node("b", 2, here["x"] + 1.0, here["y"])])
        await page.locator("#vda5050-links li[data-order=console-1]").wait_for(timeout=15_000)
        await master.send("order", b"not json")
        await page.wait_for_function(
            "() => document.querySelector('#vda5050-links .vda5050-error')?.textContent"
            ".includes('not JSON')", timeout=15_000)
    text = await line.inner_text()
    assert "order console-1" in text and "last error: the message is not JSON" in text, text
    assert not errors, errors

"""The console's "Open in Foxglove" (issue 49 item 8), in a real browser: the link is in the
top bar, its href downloads the server's Foxglove layout (valid JSON, the SDK's format), and
beside it is the URL to connect the Foxglove app to."""

from __future__ import annotations

from tests.web.conftest import Console

FETCHED = """async (href) => {
  const answer = await fetch(href);
  return { status: answer.status, type: answer.headers.get('content-type'),
           layout: await answer.json() };
}"""


async def test_open_in_foxglove_links_the_layout_and_the_url(console: Console):
    page = console.page
    link = page.locator("#foxglove-layout")
    await link.wait_for(state="visible", timeout=10_000)
    assert (await link.text_content()).strip() == "Open in Foxglove"
    assert await link.get_attribute("download")
    href = await link.evaluate("a => a.href")
    assert href == f"http://127.0.0.1:{console.server.port}/foxglove/layout.json"
    got = await page.evaluate(FETCHED, href)
    assert got["status"] == 200 and got["type"] == "application/json"
    layout = got["layout"]
    assert layout["version"] == 1 and layout["content"]["type"] == "split"
    panels = []

    def walk(node: dict) -> None:
        for child in (node.get("items") or []) + (node.get("tabs") or []):
            walk(child["content"])
        if node["type"] == "panel":
            panels.append(node["panelType"])

    walk(layout["content"])
    assert {"ThreeDee", "Teleop", "Plot", "DiagnosticsSummary"} <= set(panels)
    url = page.locator("#foxglove-url")
    assert await url.text_content() == f"ws://127.0.0.1:{console.server.port}"
    assert await url.is_visible()

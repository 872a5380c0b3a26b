"""The console's sign-in on a server with --authenticate (issue 47 item 6), in Chromium: the
box, the role badge, the token kept for the tab's life, a viewer's controls disabled with the
reason on hover, signing out."""

from __future__ import annotations

import pytest

from hitrobot_server.state.tokens import add_token, tokens_path
from tests.web.conftest import READY


@pytest.fixture
async def site(make_server, browser, tmp_path):
    state = tmp_path / "state"
    tokens = {"viewer": add_token(tokens_path(state), "hall", "viewer", None),
              "operator": add_token(tokens_path(state), "tablet", "operator", None)}
    server = await make_server(robot="sim", sim_speed=4, map_dir=str(tmp_path / "maps"),
                               authenticate=True, state_dir=str(state))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(f"page error: {e}"))
    yield page, server, tokens, errors
    assert not errors


async def sign_in(page, token: str) -> None:
    await page.locator("#signin").wait_for(state="visible", timeout=10_000)
    await page.fill("#signin-token", token)
    await page.click("#signin-ok")


async def test_a_viewer_signs_in_sees_its_badge_and_cannot_send_goals(site):
    page, server, tokens, _errors = site
    await page.goto(f"http://127.0.0.1:{server.port}/")
    assert "token" in await page.locator("#signin .why").inner_text()
    await sign_in(page, tokens["viewer"])
    await page.wait_for_function(READY, timeout=30_000)
    badge = page.locator("#role")
    await page.wait_for_function("() => document.getElementById('role').dataset.role === "
                                 "'viewer'", timeout=10_000)
    assert await badge.locator(".value").inner_text() == "hall · viewer"
    goal = page.locator("[data-tool=goal]")
    await page.wait_for_function(
        "() => document.querySelector('[data-tool=goal]').disabled", timeout=10_000)
    assert "lacks the permission 'goals'" in await goal.get_attribute("title")
    assert await page.locator("#pad button").first.is_disabled()
    assert not await page.locator("[data-tool=move]").is_disabled()
    await page.reload()  # the token is kept for the tab's life
    await page.wait_for_function("() => document.getElementById('role') && "
                                 "document.getElementById('role').dataset.role === 'viewer'",
                                 timeout=30_000)
    assert not await page.locator("#signin").count()
    await page.click("#signout")
    await page.locator("#signin").wait_for(state="visible", timeout=10_000)
    assert await page.evaluate("() => sessionStorage.getItem('hitrobot.token')") is None


async def test_a_wrong_token_is_refused_and_an_operator_may_send_goals(site):
    page, server, tokens, _errors = site
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await sign_in(page, "not-a-token")
    await page.locator("#signin").wait_for(state="visible", timeout=10_000)
    assert "Not accepted" in await page.locator("#signin .why").inner_text()
    await sign_in(page, tokens["operator"])
    await page.wait_for_function(READY, timeout=30_000)
    await page.wait_for_function("() => document.getElementById('role').dataset.role === "
                                 "'operator'", timeout=10_000)
    assert not await page.locator("[data-tool=goal]").is_disabled()
    assert await page.locator("#shell button").first.is_disabled()  # /cmd_string: admin

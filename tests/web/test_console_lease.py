"""The console shows who drives the robot (the drive lease, one driver at a time): this page,
or another client, whose driving refuses the page's own commands meanwhile, named."""

from __future__ import annotations

import asyncio

from tests.web.conftest import Console

TWIST = "geometry_msgs/Twist"


async def joystick(w, stop: asyncio.Event) -> None:
    """Another client driving at a joystick's 10 Hz until told to stop (bounded: a minute)."""
    twist = {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.4}}
    await w.publish("/cmd_vel", twist, TWIST)
    for _ in range(600):
        if stop.is_set():
            return
        await w.publish("/cmd_vel", twist)
        await asyncio.sleep(0.1)  # the drive's own rate, not a synchronisation


async def test_the_pad_shows_who_drives_and_another_drivers_name_when_refused(
        console: Console, watcher):
    page = console.page
    lease = page.locator("#drive-lease")
    assert await lease.is_hidden()
    # this page drives: the pad names its driver
    await watcher.subscribe("/drive_lease")
    await page.locator("#map").focus()
    await page.keyboard.down("ArrowUp")
    mine = await watcher.until(lambda: (watcher.latest("/drive_lease") or {}).get("holder"),
                               10, "the page holding the lease")
    await page.wait_for_function("(n) => document.querySelector('#drive-lease')"
                                 ".dataset.holder === n", arg=mine, timeout=10_000)
    assert await lease.text_content() == f"driven by {mine}"
    await page.keyboard.up("ArrowUp")
    await page.wait_for_function("() => document.querySelector('#drive-lease').hidden",
                                 timeout=10_000)  # lapsed half a second after the last command
    # another client drives: the pad names it, and this page's commands are refused naming it
    stop = asyncio.Event()
    driving = asyncio.ensure_future(joystick(watcher, stop))
    try:
        other = await watcher.until(lambda: (watcher.latest("/drive_lease") or {}).get("holder"),
                                    10, "the other client holding the lease")
        assert other != mine
        await page.wait_for_function("(n) => document.querySelector('#drive-lease')"
                                     ".dataset.holder === n", arg=other, timeout=10_000)
        assert await lease.text_content() == f"driven by {other}"
        await page.keyboard.down("ArrowLeft")
        refused = page.locator("#log li.error", has_text=f"driven by {other}")
        await refused.first.wait_for(timeout=10_000)
        await page.keyboard.up("ArrowLeft")
    finally:
        stop.set()
        await driving
    await page.wait_for_function("() => document.querySelector('#drive-lease').hidden",
                                 timeout=10_000)

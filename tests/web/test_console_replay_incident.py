"""A black-box replay shows its incident (issue 46, friction 4), in Chromium: a goal sent by
another client sends beyond the outer wall, where goals may go (unknown space: the server's
placement check lets a mapping robot explore) and no path leads, and the robot aborts it on the
live server (--black-box); the console's
Replay / Open replay opens that file's replay, which names the incident (cause, time, detail),
marks it on the timeline, plays the abort with its reason in the Navigation panel, keeps
Cancel goal and every other control that would drive off, shows no error for the black box's
services the replay has not (on a seek neither), keeps the timeline clear of the hint, the
scale and the dock, and says the recorded server's start-up line as the recording's."""

from __future__ import annotations

from tests.helpers import Watcher
from tests.web.conftest import ARTIFACTS, grid_map

ROW = "#incident-list li[data-cause=goal_aborted]"
REASON = "no free space near the target"  # the robot's reason
# what the page shows, sampled every 50 ms from its first script on
SAMPLER = """window.__seen = []; setInterval(() => {
  const box = document.getElementById('goal-status');
  const cancel = document.getElementById('cancel-goal');
  if (!box || !cancel) return;
  const live = [...document.querySelectorAll('[data-tab-panel=operate] button')]
    .filter((b) => !b.disabled);
  window.__seen.push({ replaying: document.body.classList.contains('replaying'),
    status: box.dataset.status, text: box.textContent, cancel: cancel.disabled,
    enabled: live.map((b) => b.id || b.dataset.drive || b.textContent) });
}, 50);"""
BOXES = """() => {
  const box = (sel) => document.querySelector(sel).getBoundingClientRect().toJSON();
  const dock = window.hitrobot.layers.dock.pose;
  return { bar: box('#replay-bar'), hint: box('#hint'), scale: box('#scalebar'),
           dock: dock && window.hitrobot.view.rosToClient(dock.position.x, dock.position.y) };
}"""


def overlap(a: dict, b: dict) -> bool:
    return not (a["right"] <= b["left"] or b["right"] <= a["left"] or
                a["bottom"] <= b["top"] or b["bottom"] <= a["top"])


async def test_a_black_box_replay_opens_on_its_incident(browser, make_server, tmp_path):
    folder = tmp_path / "recordings"
    server = await make_server(robot="sim", sim_speed=4, black_box=30.0, record_dir=str(folder),
                               map_dir=str(tmp_path / "maps"))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.click(".tabs [data-tab=status]")
    await page.wait_for_selector("#incidents:not([hidden])", timeout=20_000)

    other = await Watcher.open(server.port)  # another client sends the goal: beyond the wall
    try:
        await grid_map(other)
        origin = other.latest("/map")["info"]["origin"]["position"]
        x, y = origin["x"] - 3.0, origin["y"] + 2.0  # off the map's west edge, outside
        await other.publish("/move_base/goal", {"goal_id": {"id": "outside"}, "goal": {
            "target_pose": {"header": {"frame_id": "map"}, "pose": {
                "position": {"x": x, "y": y}, "orientation": {"w": 1.0}}}}},
            "move_base_msgs/MoveBaseActionGoal")
        row = page.locator(ROW)
        await row.wait_for(timeout=60_000)
    finally:
        await other.close()
    detail = await row.locator(".detail").inner_text()
    assert REASON in detail, detail

    await row.locator("button.replay").click()
    opener = row.locator("a.open-replay")
    await opener.wait_for(timeout=40_000)
    await browser.add_init_script(SAMPLER)  # in the replay's page from its start
    async with browser.expect_page(timeout=20_000) as new_page:
        await opener.click()
    replay = await new_page.value

    # the incident: its cause, time and detail, and its mark on the timeline
    line = replay.locator("#replay-incident")
    await line.wait_for(state="visible", timeout=30_000)
    text = await line.inner_text()
    assert text.startswith("Goal aborted at 20") and REASON in text, text
    mark = float(await replay.get_attribute("#replay-incident-mark", "data-position"))
    duration = float(await replay.eval_on_selector("#replay-bar .seek", "s => s.max"))
    assert 0 < mark <= duration, (mark, duration)

    # it plays through the abort, with its reason, and ends
    await replay.locator("#goal-status[data-status=aborted]").wait_for(timeout=60_000)
    aborted = await replay.locator("#goal-status").inner_text()
    assert "the robot stopped" in aborted and REASON in aborted, aborted
    seen = await replay.evaluate("window.__seen")
    # nothing that would drive was on once the page knew it shows a replay (its first
    # /replay/state): Cancel goal included, while the motion was shown
    replaying = [s for s in seen if s["replaying"]]
    assert replaying and all(s["cancel"] for s in seen), [s for s in seen if not s["cancel"]][:3]
    assert not any(s["enabled"] for s in replaying), [s for s in replaying if s["enabled"]][:3]

    # the timeline leaves the hint, the scale and the dock in view
    await replay.wait_for_function(  # the map fitted above the bar once the page knows it
        f"() => {{ const b = ({BOXES})(); return b.dock && b.dock.y + 24 <= b.bar.top; }}",
        timeout=15_000)
    boxes = await replay.evaluate(BOXES)
    assert not overlap(boxes["bar"], boxes["hint"]), boxes
    assert not overlap(boxes["bar"], boxes["scale"]), boxes
    dock, bar = boxes["dock"], boxes["bar"]
    assert dock is not None  # the dock mark and its label (to 24 px below it) above the bar
    assert dock["y"] + 24 <= bar["top"], boxes

    # a seek: no error, and the odometer counts from there
    await replay.locator("#replay-bar .seek").fill("0.5")
    await replay.wait_for_function(
        "() => Number(document.getElementById('replay-bar').dataset.position) < 2")
    await replay.wait_for_function(
        "() => Number(document.getElementById('odometry').dataset.odometer || 0) < 1",
        timeout=10_000)
    # the recorded server's start-up line is the recording's, not this server's
    logged = await replay.locator("#log li .text").all_text_contents()
    assert not [t for t in logged if t.startswith(("started fresh", "state restored"))], logged
    assert [t for t in logged if t.startswith("recorded: started fresh")], logged
    assert not [t for t in logged if "does not exist" in t], logged
    ARTIFACTS.mkdir(exist_ok=True)
    await replay.screenshot(path=str(ARTIFACTS / "console-replay-incident.png"))
    errors = [t for t in await replay.locator("#log li.error .text, #log li.warning .text")
              .all_text_contents() if "motion sent elsewhere failed" not in t]
    assert errors == [], errors

"""Issue 46, frictions 5 and 8 on the console, in Chromium: the chosen robot drawn once (its
live marker, with its name and ring; no lagging fleet marker), names on the map kept apart
(a POI's on a robot, a zone's over both robots: read from the boxes the page placed), the
odometer counting no set pose, the panels above the Drive pad never under it at 1400×860, the
zone form's hint apart from the map's, and sonars red only when something is near."""

from __future__ import annotations

import re

from tests.helpers import Watcher
from tests.web.conftest import Console, add_poi
from tests.web.test_fleet import Y, fleet_console  # noqa: F401 (a fixture)
from tests.web.test_zones import polygon

ROBOTS = """() => window.hitrobot.fleet.robots.map((r) => ({ name: r.name,
  ...window.hitrobot.view.rosToClient(r.pose.position.x, r.pose.position.y) }))"""


def overlap(a: dict, b: dict) -> bool:
    return a["left"] < b["right"] and b["left"] < a["right"] and \
        a["top"] < b["bottom"] and b["top"] < a["bottom"]


async def test_the_chosen_robot_is_drawn_once_and_names_keep_apart(
        fleet_console: Console):  # noqa: F811
    c, page = fleet_console, fleet_console.page
    w = await Watcher.open(c.server.port)
    try:
        # a POI where robot a stands, a zone over both robots' row
        await add_poi(w, "on a", 4.0, Y)
        await page.wait_for_selector('#poi-list li[data-name="on a"]')
        added = await w.call("/fleet/zone_add", {"name": "the_row", "kind": "corridor",
                                                 "polygon": polygon([(3.0, 7.0), (13.0, 7.0),
                                                                     (13.0, 9.0), (3.0, 9.0)])},
                             timeout=30)
        assert added["values"]["success"], added
        await page.wait_for_selector("#zones-list li[data-zone=the_row]")
        await c.frame()
        # drawn once: the fleet layer draws b only; a is its live marker, named, with its ring
        drawn = await page.evaluate("""() => ({
          fleet: window.hitrobot.fleet.layer.node.children.length,
          label: window.hitrobot.robot.label && window.hitrobot.robot.label.text })""")
        assert drawn == {"fleet": 1, "label": "a · idle"}, drawn
        boxes = await page.evaluate("() => window.hitrobot.view.labelBoxes")
        names = sorted(b["name"] for b in boxes)
        assert names == sorted(["a · idle", "b", "on a", "the_row"]), names
        for i, a in enumerate(boxes):
            for b in boxes[i + 1:]:
                assert not overlap(a, b), (a, b)
        # no name over a robot's body (9 px at least around its centre)
        for robot in await page.evaluate(ROBOTS):
            body = {"left": robot["x"] - 9, "right": robot["x"] + 9,
                    "top": robot["y"] - 9, "bottom": robot["y"] + 9}
            assert not [b for b in boxes if overlap(b, body)], (robot, boxes)
        # the zone form's hint and the map's hint do not overlap
        await page.click("#zone-draw")
        hints = await page.evaluate("""() => [document.querySelector('#zone-form .hint'),
          document.getElementById('hint')].map((e) => e.getBoundingClientRect().toJSON())""")
        assert not overlap(*hints), hints
        await page.click("#zone-cancel")
    finally:
        await w.close()
    assert c.errors == []


async def test_the_odometer_counts_no_set_pose(console: Console, watcher):
    page = console.page
    await page.wait_for_function("() => window.hitrobot.robotActions.last !== null")
    start = await page.evaluate("() => window.hitrobot.robotActions.last")  # odom's x, y
    pose = await page.evaluate("() => window.hitrobot.state.pose")
    far = (pose["x"] + 4.0, pose["y"])  # 4 m away in one step: set there, not driven
    await watcher.publish("/initialpose", {
        "header": {"frame_id": "map"},
        "pose": {"pose": {"position": {"x": far[0], "y": far[1], "z": 0.0},
                          "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
                 "covariance": [0.0] * 36}}, "geometry_msgs/PoseWithCovarianceStamped")
    await page.wait_for_function(
        "(x) => Math.abs(window.hitrobot.state.pose.x - x) < 0.5", arg=far[0], timeout=15_000)
    # the odometry read after the jump (odom jumps with the pose on this robot)
    await page.wait_for_function("""(s) => { const l = window.hitrobot.robotActions.last;
        return Math.hypot(l.x - s.x, l.y - s.y) > 3; }""", arg=start, timeout=15_000)
    text = await page.text_content("#odometry")
    odometer = float(re.search(r"odometer ([\d.]+) m", text).group(1))
    assert odometer < 1.0, text


async def test_the_panels_above_the_drive_pad_are_never_under_it(console: Console):
    page = console.page
    await page.set_viewport_size({"width": 1400, "height": 860})
    await console.frame()
    covered = await page.evaluate("""() => {
      const drive = document.getElementById('drive-panel').getBoundingClientRect();
      const parts = [...document.querySelectorAll(
        '#patrol-panel button, #poi-list, #patrol-panel h2')];
      const out = [];
      for (const tab of [0, 1]) {
        const scroller = document.querySelector('[data-tab-panel=operate]');
        for (const box of [scroller, ...scroller.querySelectorAll('*')]) {
          if (box.scrollHeight > box.clientHeight + 1 &&
              getComputedStyle(box).overflowY === 'auto') {
            box.scrollTop = tab ? box.scrollHeight : 0;
          }
        }
        for (const part of parts) {
          // what of the part is shown: its box clipped by every scrolling box around it
          let r = part.getBoundingClientRect().toJSON();
          for (let p = part.parentElement; p; p = p.parentElement) {
            if (!/auto|hidden|scroll/.test(getComputedStyle(p).overflowY)) continue;
            const c = p.getBoundingClientRect();
            r = { left: Math.max(r.left, c.left), right: Math.min(r.right, c.right),
                  top: Math.max(r.top, c.top), bottom: Math.min(r.bottom, c.bottom) };
          }
          if (r.bottom <= r.top || r.right <= r.left) continue; // scrolled out of view
          if (r.top < drive.bottom && drive.top < r.bottom &&
              r.left < drive.right && drive.left < r.right) {
            out.push({ part: part.id || part.textContent.trim(), shown: r, drive: drive.toJSON() });
          }
        }
      }
      return out;
    }""")
    assert covered == [], covered
    # the pad is still in view and the Messages below it
    pad = await page.evaluate(
        "() => document.getElementById('pad').getBoundingClientRect().toJSON()")
    assert pad["bottom"] <= 860 and pad["top"] >= 0, pad
    assert console.errors == []


async def test_sonars_are_red_only_when_something_is_near(console: Console):
    page = console.page
    await console.tab("status")
    await page.wait_for_selector("#sensors li[data-id]", timeout=15_000)
    rows = await page.evaluate("""() => [...document.querySelectorAll('#sensors li')]
      .filter((li) => li.textContent.startsWith('sonar')).map((li) => ({
        text: li.children[1].textContent, hit: Boolean(li.querySelector('.hit')) }))""")
    assert rows, "no sonar listed"
    for row in rows:
        m = re.search(r"([\d.]+) m", row["text"])
        near = m is not None and 0 < float(m.group(1)) < 0.5
        assert row["hit"] == near, rows
    assert any(not row["hit"] for row in rows), rows  # the simulator's robot stands in the open

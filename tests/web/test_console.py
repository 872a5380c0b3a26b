"""The web console in a real browser against a real server driving the simulated robot."""

from __future__ import annotations

import asyncio
import math
import os
import time

import numpy as np

from tests.web.conftest import ARTIFACTS, REPO, Console, add_poi, grid_map, yaw_of

ODOM = "/slamware_ros_sdk_server_node/odom"
ROBOT_BLUE = np.array([0x21, 0x96, 0xF3])


def near_colour(img: np.ndarray, colour, tol: float = 40) -> np.ndarray:
    return np.linalg.norm(img - np.asarray(colour), axis=2) < tol


async def overlay_rects(console: Console) -> list[dict]:
    """Screen boxes of what floats over the map (toolbar, hint, cursor readout)."""
    return await console.page.evaluate("""() => [...document.querySelectorAll(
        '.toolbar .group, .hint, .cursor, .toasts > *')]
        .map(e => e.getBoundingClientRect().toJSON())""")


def covered(x: float, y: float, rects: list[dict], pad: float = 4) -> bool:
    return any(r["left"] - pad <= x <= r["right"] + pad and r["top"] - pad <= y <= r["bottom"] + pad
               for r in rects)


async def test_page_loads_without_console_errors(console: Console):
    page = console.page
    # the page has heard from the bridge, the robot's state, its pose and the map
    await page.wait_for_function("""() => {
        const text = (sel) => (document.querySelector(sel) || {}).textContent || '';
        return window.hitrobot && window.hitrobot.view.mapBounds !== null
            && text('#bridge-state .value') === 'connected'
            && document.querySelector('#robot-state').dataset.state === 'ok'
            && text('#battery .value').endsWith('%')
            && text('#robot-pose').includes('robot at');
    }""", timeout=10_000)
    assert console.errors == []
    libraries = await page.evaluate("window.hitrobot.libraries")
    assert libraries["roslib"].startswith("1.") and libraries["ros2d"] == "0.10.0"
    assert await page.text_content("#bridge-state .value") == "connected"
    assert await page.get_attribute("#robot-state", "data-state") == "ok"
    assert (await page.text_content("#battery .value")).endswith("%")
    assert await page.locator("#log li.error, #log li.warning").count() == 0
    assert "robot at" in await page.text_content("#robot-pose")


async def test_map_canvas_shows_the_map(console: Console, watcher):
    grid = await grid_map(watcher)
    await console.frame()
    img = await console.screenshot_array()
    box = await console.page.locator("#map canvas").bounding_box()
    top, left = int(box["y"]), int(box["x"])
    canvas = img[top:top + int(box["height"]), left:left + int(box["width"])]
    assert canvas.std() > 40, "the map canvas is blank"
    assert "png" in console.ops, "the map did not come png-compressed (as ros2d asks)"
    rects = await overlay_rects(console)
    robot = watcher.latest("/robot_pose") or {}
    rx, ry = (robot.get("position", {}).get(k, -99) for k in ("x", "y"))

    async def sample(cells, limit=150):
        rng = np.random.default_rng(0)
        picks = rng.choice(len(cells), size=min(limit, len(cells)), replace=False)
        values = []
        for i in picks:
            x, y = grid.centre(*cells[i])
            if math.hypot(x - rx, y - ry) < 0.8:
                continue
            cx, cy = await console.to_client(x, y)
            if covered(cx, cy, rects) or not (0 <= cy < img.shape[0] and 0 <= cx < img.shape[1]):
                continue
            values.append(img[int(cy), int(cx)])
        assert len(values) > 30
        return np.array(values)

    walls = await sample(grid.interior(100, 2))
    free = await sample(grid.interior(0, 4))
    dark = (walls.max(axis=1) < 80).mean()
    light = (free.min(axis=1) > 200).mean()
    assert dark > 0.9, f"only {dark:.0%} of wall cells are drawn dark"
    assert light > 0.9, f"only {light:.0%} of free cells are drawn light"
    assert console.errors == []


async def test_robot_marker_sits_at_the_robot_pose(console: Console, watcher):
    await watcher.subscribe("/robot_pose", "geometry_msgs/Pose")
    pose = await watcher.next("/robot_pose")
    await console.page.wait_for_function(  # the marker has been placed at that pose
        """([x, y]) => { const p = window.hitrobot.robot.pose;
                        return p && Math.hypot(p.x - x, p.y - y) < 0.05; }""",
        arg=[pose["position"]["x"], pose["position"]["y"]], timeout=10_000)
    await console.frame()
    img = await console.screenshot_array()
    ex, ey = await console.to_client(pose["position"]["x"], pose["position"]["y"])
    x0, y0 = int(ex) - 40, int(ey) - 40
    window = img[y0:y0 + 80, x0:x0 + 80]
    ys, xs = np.nonzero(near_colour(window, ROBOT_BLUE))
    assert len(xs) > 50, "no robot marker near the robot's pose"
    cx = x0 + (xs.min() + xs.max() + 1) / 2
    cy = y0 + (ys.min() + ys.max() + 1) / 2
    assert math.hypot(cx - ex, cy - ey) <= 3, ((cx, cy), (ex, ey))
    # and the page's own record of the marker agrees with the bus
    marker = await console.page.evaluate("window.hitrobot.robot.pose")
    assert abs(marker["x"] - pose["position"]["x"]) < 0.05
    assert abs(marker["y"] - pose["position"]["y"]) < 0.05


async def decorate(watcher) -> None:
    """A virtual wall and two POIs, so the screenshot shows what the console draws."""
    await watcher.publish("/slamware_ros_sdk_server_node/add_line", {
        "usage": {"usage": 0},
        "line": {"id": 0, "start": {"x": 18.0, "y": 1.6}, "end": {"x": 22.5, "y": 1.6}},
    }, "slamware_ros_sdk/AddLineRequest")
    for name, x, y in (("reception", 2.0, 8.0), ("kitchen", 13.5, 3.0)):
        await add_poi(watcher, name, x, y)


async def test_goal_dragged_on_the_map_takes_the_robot_there(console: Console, watcher):
    page = console.page
    grid = await grid_map(watcher)
    await watcher.subscribe(ODOM, "nav_msgs/Odometry")
    start = (await watcher.next(ODOM))["pose"]["pose"]["position"]
    await decorate(watcher)
    # a spot in the upper right room (the office world), with room around it
    gx, gy = grid.nearest_clear(19.0, 12.5)
    sx, sy = await console.to_client(gx, gy)
    await page.click("[data-tool=goal]")
    await console.drag((sx, sy), (sx, sy - 50))  # drag up the screen: face +y (north)
    sent = time.monotonic()

    total = math.hypot(gx - start["x"], gy - start["y"])
    shot = False
    while True:
        assert time.monotonic() - sent < 90, "the robot did not arrive"
        odom = await watcher.next(ODOM)
        p = odom["pose"]["pose"]
        left = math.hypot(gx - p["position"]["x"], gy - p["position"]["y"])
        if not shot and left < total * 0.6:
            await console.frame()
            ARTIFACTS.mkdir(exist_ok=True)
            png = await page.screenshot(path=str(ARTIFACTS / "console-mid-route.png"))
            if os.environ.get("UPDATE_SCREENSHOT") == "1":
                (REPO / "web" / "screenshot.png").write_bytes(png)
            shot = True
            assert await page.get_attribute("#goal-status", "data-status") == "active"
            assert await page.locator("#cancel-goal").is_enabled()
        if left < 0.15 and abs(yaw_of(p["orientation"]) - math.pi / 2) < 0.2:
            break
    await console.wait_data("#goal-status", "status", "succeeded")
    assert "SUCCEEDED" in await page.text_content("#goal-status")
    assert console.errors == []


async def test_cancel_stops_the_goal(console: Console, watcher):
    page = console.page
    grid = await grid_map(watcher)
    gx, gy = grid.nearest_clear(20.0, 3.0)
    await page.click("[data-tool=goal]")
    sx, sy = await console.to_client(gx, gy)
    await page.mouse.click(sx, sy)  # a click: heading from the robot towards the goal
    await console.wait_data("#goal-status", "status", "active")
    await page.click("#cancel-goal")
    await console.wait_data("#goal-status", "status", "preempted")
    # roslibjs 1.4.1 cancels with a GoalID without stamp: that is normal, no warning about it
    assert await page.locator("#log li.warning, #log li.error").count() == 0
    assert await page.locator(".toast").count() == 0
    await watcher.subscribe(ODOM, "nav_msgs/Odometry")

    def speed() -> float:
        odom = watcher.latest(ODOM)
        return abs(odom["twist"]["twist"]["linear"]["x"]) if odom else math.inf

    await watcher.until(lambda: speed() < 0.05, 5, "the robot slowing down")
    twist = (await watcher.next(ODOM))["twist"]["twist"]
    assert abs(twist["linear"]["x"]) < 0.05
    assert await page.locator("#cancel-goal").is_disabled()


async def test_set_pose_publishes_initialpose(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/initialpose", "geometry_msgs/PoseWithCovarianceStamped")
    grid = await grid_map(watcher)
    px, py = grid.nearest_clear(7.0, 8.0)
    sx, sy = await console.to_client(px, py)
    await page.click("[data-tool=pose]")
    await console.drag((sx, sy), (sx - 50, sy))  # face -x
    msg = await watcher.until(lambda: watcher.latest("/initialpose"), 10, "/initialpose")
    expected = await page.evaluate("([x, y]) => window.hitrobot.view.clientToRos(x, y)", [sx, sy])
    pose = msg["pose"]["pose"]
    assert abs(pose["position"]["x"] - expected["x"]) < 1e-6
    assert abs(pose["position"]["y"] - expected["y"]) < 1e-6
    assert abs(abs(yaw_of(pose["orientation"])) - math.pi) < 0.05
    assert msg["header"]["frame_id"] == "map"
    # the robot is now there (the simulator takes the pose)
    await watcher.subscribe("/robot_pose", "geometry_msgs/Pose")
    await watcher.until(lambda: (r := watcher.latest("/robot_pose")) and
                        math.hypot(r["position"]["x"] - px, r["position"]["y"] - py) < 0.3,
                        10, "the robot at the new pose")
    assert await page.get_attribute("#tools [data-tool=move]", "class") == "active"


async def test_poi_added_renamed_and_deleted_in_the_page(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/map_manager/pois", "map_messages/PointsOfInterest")
    grid = await grid_map(watcher)
    px, py = grid.nearest_clear(3.0, 13.0)
    sx, sy = await console.to_client(px, py)
    await page.click("[data-tool=poi]")
    await page.mouse.click(sx, sy)
    dialog = page.locator("#poi-dialog")
    await dialog.locator("input[name=name]").fill("charging corner")
    await dialog.locator("input[name=remarks]").fill("by the window")
    await dialog.locator("#poi-save").click()

    def named(name):
        pois = (watcher.latest("/map_manager/pois") or {}).get("pois", [])
        return next((p for p in pois if p["name"] == name), None)

    poi = await watcher.until(lambda: named("charging corner"), 10, "the POI on /map_manager/pois")
    expected = await page.evaluate("([x, y]) => window.hitrobot.view.clientToRos(x, y)", [sx, sy])
    assert poi["type"] == 100 and poi["remarks"] == "by the window"
    assert abs(poi["pose"]["position"]["x"] - expected["x"]) < 1e-4
    assert abs(poi["pose"]["position"]["y"] - expected["y"]) < 1e-4
    item = page.locator('#poi-list li[data-name="charging corner"]')
    await item.wait_for()

    await item.locator("button.rename").click()
    await dialog.locator("input[name=name]").fill("dock corner")
    await dialog.locator("#poi-save").click()
    await watcher.until(lambda: named("dock corner") and not named("charging corner"), 10,
                        "the renamed POI")
    item = page.locator('#poi-list li[data-name="dock corner"]')
    await item.wait_for()

    await item.locator("button.delete").click()
    await page.locator("#confirm-ok").click()
    await watcher.until(lambda: watcher.latest("/map_manager/pois") is not None
                        and not named("dock corner"), 10, "the POI gone")
    await page.locator('#poi-list li[data-name="dock corner"]').wait_for(state="detached")
    assert console.errors == []


async def test_go_to_poi_button_navigates(console: Console, watcher):
    page = console.page
    grid = await grid_map(watcher)
    px, py = grid.nearest_clear(9.0, 8.0)
    await add_poi(watcher, "corridor", px, py)
    await watcher.subscribe(ODOM, "nav_msgs/Odometry")
    item = page.locator('#poi-list li[data-name="corridor"]')
    await item.wait_for()
    await item.locator("button.go").click()

    def arrived():
        odom = watcher.latest(ODOM)
        p = odom and odom["pose"]["pose"]["position"]
        return p and math.hypot(p["x"] - px, p["y"] - py) < 0.3

    await watcher.until(arrived, 60, "the robot at the POI")


async def test_mode_buttons_change_the_indicator(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/system_shell/system_mode", "std_msgs/String")
    await console.tab("status")
    await page.click("[data-cmd=gmapping]")
    await console.wait_data("#mode", "mode", "gmapping", timeout=15)
    assert await page.text_content("#mode .value") == "mapping"
    assert watcher.latest("/system_shell/system_mode")["data"] == "gmapping"
    assert "current" in await page.get_attribute("[data-cmd=gmapping]", "class")
    await page.click("[data-cmd=navigation]")
    await console.wait_data("#mode", "mode", "navigation", timeout=15)
    assert await page.text_content("#mode .value") == "navigation"
    seen = [m["data"] for _, m in watcher.messages["/system_shell/system_mode"]]
    assert "busy" in seen and seen[-1] == "navigation"
    assert console.errors == []


async def test_reboot_asks_first_and_version_answers(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/system_shell/cmd_string", "std_msgs/String")
    await console.tab("status")
    await page.click("[data-cmd=reboot]")
    dialog = page.locator("#confirm-dialog")
    await dialog.wait_for()
    assert "Reboot" in await dialog.text_content()
    await dialog.locator("button[value=cancel]").click()
    await asyncio.sleep(0.5)  # a window for a (wrong) command to arrive: none may
    assert watcher.messages.get("/system_shell/cmd_string") is None
    await console.wait_data("#robot-state", "state", "ok")  # the robot's state has arrived
    assert await page.get_attribute("#robot-state", "data-state") == "ok"

    await page.click("[data-cmd=version]")
    await watcher.until(lambda: watcher.latest("/system_shell/cmd_string"), 5, "the command")
    assert watcher.latest("/system_shell/cmd_string")["data"] == "version"
    await page.locator("#log li", has_text="version:").first.wait_for()
    assert await page.text_content("#version")


async def test_arrow_keys_drive_and_release_stops(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/cmd_vel", "geometry_msgs/Twist")
    await page.locator("#map").focus()
    await page.keyboard.down("ArrowUp")
    await watcher.until(lambda: len(watcher.messages.get("/cmd_vel", [])) >= 4, 5,
                        "four drive commands while the key is held")
    sent = [m for _, m in watcher.messages.get("/cmd_vel", [])]
    assert len(sent) >= 4, sent  # 10 per second while held
    assert all(abs(m["linear"]["x"] - 0.3) < 1e-9 and m["angular"]["z"] == 0 for m in sent)
    await page.keyboard.down("ArrowLeft")
    twist = await watcher.next("/cmd_vel")
    assert twist["angular"]["z"] > 0 and twist["linear"]["x"] > 0
    await page.keyboard.up("ArrowLeft")
    await page.keyboard.up("ArrowUp")
    await watcher.until(lambda: watcher.latest("/cmd_vel")["linear"]["x"] == 0, 5,
                        "the stop command on release")
    last = watcher.latest("/cmd_vel")
    assert last["linear"]["x"] == 0 and last["angular"]["z"] == 0
    count = len(watcher.messages["/cmd_vel"])
    await asyncio.sleep(0.5)
    assert len(watcher.messages["/cmd_vel"]) == count, "kept publishing after release"

    # the on-screen pad: hold, then the pointer leaves the window's focus (blur) → stop
    await page.locator("#pad .right").scroll_into_view_if_needed()  # the Operate tab scrolls
    pad = await page.locator("#pad .right").bounding_box()
    await page.mouse.move(pad["x"] + pad["width"] / 2, pad["y"] + pad["height"] / 2)
    await page.mouse.down()
    twist = await watcher.next("/cmd_vel")
    assert twist["angular"]["z"] < 0
    await page.evaluate("window.dispatchEvent(new Event('blur'))")
    await watcher.until(lambda: watcher.latest("/cmd_vel")["angular"]["z"] == 0, 5,
                        "the stop command on blur")
    last = watcher.latest("/cmd_vel")
    assert last["linear"]["x"] == 0 and last["angular"]["z"] == 0
    await page.mouse.up()
    assert await page.text_content("#drive-state") == "stopped"


async def test_status_errors_are_shown(console: Console):
    page = console.page
    # publish the wrong type on /cmd_vel: the server answers with a status error
    await page.evaluate("""() => new ROSLIB.Topic({ ros: window.hitrobot.ros, name: '/cmd_vel',
        messageType: 'std_msgs/String' }).publish({ data: 'oops' })""")
    entry = page.locator("#log li.error").first
    await entry.wait_for(timeout=5_000)
    assert "/cmd_vel" in await entry.text_content()
    assert await page.locator(".toast.error").count() == 1  # one failure, one toast


async def test_page_comes_back_after_the_server_restarts(console: Console, make_server, tmp_path):
    page = console.page
    port = console.server.port
    await console.server.stop()
    await console.wait_data("#bridge-state", "state", "down")
    assert "retrying" in await page.text_content("#bridge-state")
    assert await page.locator("#log li.error", has_text="lost the connection").count() == 1
    assert await page.evaluate("document.body.classList.contains('offline')")
    await make_server(robot="sim", sim_speed=4, map_dir=str(tmp_path / "maps"), port=port)
    # the page reloads itself once the bridge answers, and subscribes afresh
    await page.wait_for_function(
        "() => window.hitrobot && window.hitrobot.ros.isConnected && window.hitrobot.state.pose",
        timeout=20_000)
    await console.wait_data("#bridge-state", "state", "up")
    assert not await page.evaluate("document.body.classList.contains('offline')")

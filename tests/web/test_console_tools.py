"""The console's second floor in a real browser: map editing, saved maps, robot actions,
patrols, diagnostics, the offline state and the topic inspector, against the simulator."""

from __future__ import annotations

import math
import shutil

import numpy as np

from tests.helpers import Watcher
from tests.web.conftest import REPO, Console, GridMap, add_poi, grid_map

NODE = "/slamware_ros_sdk_server_node"
ODOM = f"{NODE}/odom"
PLAN = f"{NODE}/global_plan_path"
STATE = f"{NODE}/robot_basic_state"


Point = tuple[float, float]


def crosses(path: list[Point], a: Point, b: Point) -> bool:
    """Whether the polyline ``path`` crosses the segment a–b."""
    def side(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    for p, q in zip(path, path[1:], strict=False):
        if side(a, b, p) * side(a, b, q) < 0 and side(p, q, a) * side(p, q, b) < 0:
            return True
    return False


def plan_points(msg: dict) -> list[tuple[float, float]]:
    return [(p["pose"]["position"]["x"], p["pose"]["position"]["y"]) for p in msg["poses"]]


async def simple_goal(watcher, x: float, y: float) -> None:
    """Send the robot to (x, y) from another client (/move_base_simple/goal)."""
    await watcher.publish("/move_base_simple/goal", {
        "header": {"frame_id": "map"},
        "pose": {"position": {"x": x, "y": y, "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
        "geometry_msgs/PoseStamped")


async def click_map(console: Console, x: float, y: float) -> None:
    await console.page.mouse.click(*(await console.to_client(x, y)))


async def wait_plan(watcher, pred, what: str, timeout: float = 20) -> list[tuple[float, float]]:
    msg = await watcher.until(lambda: (m := watcher.latest(PLAN)) and len(m["poses"]) > 1
                              and pred(plan_points(m)) and m, timeout, what)
    return plan_points(msg)


async def test_a_wall_drawn_in_the_page_makes_the_planned_path_detour(console: Console, watcher):
    page = console.page
    await watcher.subscribe(PLAN, "nav_msgs/Path")
    await watcher.subscribe(f"{NODE}/virtual_walls", "slamware_ros_sdk/Line2DFlt32Array")
    # the corridor runs along y 7.0–9.2 m; the robot starts in it at (5, 8)
    goal = (16.0, 8.0)
    wall = ((12.0, 6.8), (12.0, 8.4))  # leaves a gap at the corridor's upper side
    await page.click("[data-tool=goal]")
    await click_map(console, *goal)
    await wait_plan(watcher, lambda pts: crosses(pts, *wall),
                    "a straight plan through the wall's place")
    await page.click("#cancel-goal")
    await console.wait_data("#goal-status", "status", "preempted")

    await console.tab("map")
    await page.click("[data-tool=wall]")
    await console.drag(await console.to_client(*wall[0]), await console.to_client(*wall[1]))
    msg = await watcher.until(lambda: (m := watcher.latest(f"{NODE}/virtual_walls")) and m["lines"]
                              and m, 10, "the wall on virtual_walls")
    line = msg["lines"][0]
    drawn = await page.evaluate("([x, y]) => window.hitrobot.view.clientToRos(x, y)",
                                list(await console.to_client(*wall[0])))
    assert abs(line["start"]["x"] - drawn["x"]) < 1e-3
    assert abs(line["start"]["y"] - drawn["y"]) < 1e-3
    assert abs(line["end"]["y"] - 8.4) < 0.05
    await page.locator("#line-counts", has_text="1 wall ·").wait_for()

    await page.click("[data-tool=goal]")
    await click_map(console, *goal)
    wall_now = ((line["start"]["x"], line["start"]["y"]), (line["end"]["x"], line["end"]["y"]))
    detour = await wait_plan(watcher, lambda pts: not crosses(pts, *wall_now)
                             and abs(pts[-1][0] - goal[0]) < 0.3, "a plan around the wall")
    at_wall = min(detour, key=lambda p: abs(p[0] - 12.0))
    assert at_wall[1] > 8.4, f"the plan passes x = 12 at y = {at_wall[1]:.2f}, not through the gap"
    await page.check("[data-layer=costmap]")
    await page.wait_for_function("() => Boolean(window.hitrobot.layers.costmap.cells)")
    await console.snapshot("console-map-editing")
    assert console.errors == []


async def test_save_as_then_load_a_saved_map_from_the_list(console: Console, watcher):
    page = console.page
    await console.tab("map")
    await page.locator("#map-list li.empty").wait_for()
    await page.click("#map-save-as")
    dialog = page.locator("#name-dialog")
    await dialog.locator("input[name=name]").fill("bad name/")
    await dialog.locator("#name-ok").click()
    assert "letters, digits" in await dialog.locator(".form-error").text_content()
    assert await dialog.locator("input[name=name]").input_value() == "bad name/"
    await dialog.locator("input[name=name]").fill("ground_floor")
    await dialog.locator("#name-ok").click()
    confirm = page.locator("#confirm-dialog")
    item = page.locator('#map-list li[data-name="ground_floor"]')
    await item.wait_for(timeout=15_000)
    assert (console.server.settings.store.map_store / "ground_floor" / "map.yaml").is_file()

    # change the robot's state, then load the saved map back from the list
    await watcher.subscribe(f"{NODE}/virtual_walls", "slamware_ros_sdk/Line2DFlt32Array")
    await watcher.publish(f"{NODE}/add_line", {
        "usage": {"usage": 0}, "line": {"id": 0, "start": {"x": 18.0, "y": 1.6},
                                         "end": {"x": 22.5, "y": 1.6}}},
        "slamware_ros_sdk/AddLineRequest")
    await watcher.until(lambda: (m := watcher.latest(f"{NODE}/virtual_walls")) and m["lines"], 10,
                        "the added wall")
    await item.locator("button.load").click()
    await confirm.locator(".question", has_text="Load the map “ground_floor”").wait_for()
    await page.click("#confirm-ok")
    loaded = page.locator("#log li", has_text="map “ground_floor”: Map loaded.")
    await loaded.wait_for(timeout=15_000)
    await watcher.until(lambda: watcher.latest(f"{NODE}/virtual_walls")["lines"] == [], 10,
                        "the saved map's walls (none) back")
    await page.locator('#map-list li[data-name="ground_floor"]', has_text="loaded").wait_for()
    assert console.errors == []


async def test_relocalize_raises_a_low_localization_quality(console: Console, watcher):
    page = console.page
    await watcher.subscribe(STATE, "slamware_ros_sdk/RobotBasicState")
    # a wrong "Set pose": the robot believes it is somewhere else, the scan no longer matches
    await page.click("[data-tool=pose]")
    await console.drag(await console.to_client(14.0, 3.0), await console.to_client(14.0, 4.0))
    await watcher.until(lambda: (s := watcher.latest(STATE)) and s["localization_quality"] < 50,
                        15, "a low localization quality")
    warning = page.locator("#loc-warning")
    await warning.wait_for(state="visible")
    assert await page.get_attribute("#loc-state", "data-state") == "low"
    low = page.locator("#log li.warning", has_text="localization quality is low")
    assert await low.count() == 1
    await page.click("#relocalize")
    await watcher.until(lambda: watcher.latest(STATE)["localization_quality"] >= 80, 30,
                        "the quality back up")
    await warning.wait_for(state="hidden")
    assert await page.get_attribute("#loc-state", "data-state") == "ok"


async def test_go_home_docks_and_the_page_shows_charging(console: Console, watcher):
    page = console.page
    await watcher.subscribe(STATE, "slamware_ros_sdk/RobotBasicState")
    assert await page.get_attribute("#charge-state", "data-state") == "discharging"
    await page.click("#go-home")
    await console.wait_data("#charge-state", "state", "charging", timeout=90)
    assert watcher.latest(STATE)["is_charging"]
    assert "charging" in await page.text_content("#charge-state")
    assert await page.get_attribute("#battery", "data-state") == "charging"


async def test_patrol_of_three_clicked_waypoints_visits_them_in_order(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/planning/patrol_state", "hitrobot_msgs/PatrolState")
    await watcher.subscribe(ODOM, "nav_msgs/Odometry")
    # out and back along the corridor: the second waypoint lies between the start and the first
    points = [(11.0, 8.0), (7.0, 8.6), (9.0, 7.5)]
    await page.click("[data-tool=waypoint]")
    for i, (x, y) in enumerate(points, 1):
        await click_map(console, x, y)
        await page.locator("#waypoint-list li").nth(i - 1).wait_for()
    state = watcher.latest("/planning/patrol_state")
    clicked = [await page.evaluate("([x, y]) => window.hitrobot.view.clientToRos(x, y)",
                                   list(await console.to_client(x, y))) for x, y in points]
    assert [(w["x"], w["y"]) for w in state["waypoints"]] == \
        [(pytest_approx(c["x"]), pytest_approx(c["y"])) for c in clicked]
    await page.keyboard.press("Escape")
    await page.click("[data-tool=move]")
    await page.click("#patrol-start")

    await console.wait_data("#patrol-state", "active", "true")

    def targets() -> list[tuple[float, int]]:
        """(time, target) each time the running patrol's target changed."""
        out: list[tuple[float, int]] = []
        for at, msg in watcher.messages["/planning/patrol_state"]:
            if msg["active"] and (not out or out[-1][1] != msg["target_index"]):
                out.append((at, msg["target_index"]))
        return out

    await watcher.until(lambda: len(targets()) >= 4, 120, "a full lap of the patrol")
    changes = targets()
    assert [t for _, t in changes[:4]] == [0, 1, 2, 0]
    odoms = watcher.messages[ODOM]
    for (at, _), (_, before) in zip(changes[1:4], changes[:3], strict=True):
        # when the patrol moved on, the robot was at the waypoint it had been heading to
        p = min(odoms, key=lambda o: abs(o[0] - at))[1]["pose"]["pose"]["position"]
        w = state["waypoints"][before]
        assert math.hypot(p["x"] - w["x"], p["y"] - w["y"]) < 0.6, (before, p)
    await page.locator("#waypoint-list li.target").wait_for()
    await console.snapshot("console-patrol")
    await page.click("#patrol-stop")
    await console.wait_data("#patrol-state", "active", "false")


def pytest_approx(v: float):
    import pytest
    return pytest.approx(v, abs=1e-6)


async def test_diagnostics_panel_shows_an_injected_localization_fault(console: Console, watcher):
    """The fault: a wrong initial pose (a real client publishing /initialpose), which the
    simulator's scan matching reports as a low localization quality → /Robot/Localization."""
    page = console.page
    await console.tab("status")
    item = page.locator('#diagnostics li[data-name="/Robot/Localization"]')
    await item.wait_for()
    assert await item.get_attribute("data-level") == "OK"
    await watcher.publish("/initialpose", {
        "header": {"frame_id": "map"},
        "pose": {"pose": {"position": {"x": 14.0, "y": 3.0, "z": 0.0},
                          "orientation": {"x": 0.0, "y": 0.0, "z": 0.7071, "w": 0.7071}},
                 "covariance": [0.0] * 36}}, "geometry_msgs/PoseWithCovarianceStamped")
    await page.wait_for_function("""() => ['WARN', 'ERROR'].includes(document.querySelector(
        '#diagnostics li[data-name="/Robot/Localization"]').dataset.level)""", timeout=15_000)
    assert "quality" in await item.text_content()
    assert await page.get_attribute("#diag-summary", "data-level") in ("WARN", "ERROR")
    await page.locator('#sensors li[data-id]').first.wait_for()
    await console.snapshot("console-diagnostics")


async def test_offline_disables_tools_and_goals_and_sends_nothing(console: Console):
    page = console.page
    await page.click("[data-tool=goal]")
    await console.server.stop()
    await console.wait_data("#bridge-state", "state", "down")
    await console.wait_data("#goal-status", "status", "offline")
    assert "OFFLINE" in await page.text_content("#goal-status")
    for tool in ("goal", "pose", "poi"):
        assert await page.locator(f"#tools [data-tool={tool}]").is_disabled()
    assert await page.locator("#tools [data-tool=move]").is_enabled()
    assert await page.get_attribute("#tools [data-tool=move]", "class") == "active"
    assert await page.locator("#cancel-goal").is_disabled()
    assert await page.locator("#relocalize").is_disabled()
    # a click on the map and the keyboard shortcut send nothing
    await click_map(console, 10.0, 8.0)
    await page.locator("#map").focus()
    await page.keyboard.press("g")
    assert await page.get_attribute("#tools [data-tool=move]", "class") == "active"
    await page.keyboard.down("ArrowUp")
    assert await page.get_attribute("#drive-state", "data-state") == "offline"
    await page.keyboard.up("ArrowUp")
    assert await page.evaluate("window.hitrobot.navigator.sendGoal(10, 8, 0)") is None
    await page.locator("#log li.error", has_text="goal not sent: the bridge is offline").wait_for()
    assert await page.locator("#log li", has_text="goal sent").count() == 0


async def test_duplicate_poi_name_keeps_the_dialog_and_input(console: Console, watcher):
    page = console.page
    await add_poi(watcher, "lobby", 6.0, 8.0)
    await page.locator('#poi-list li[data-name="lobby"]').wait_for()
    await page.click("[data-tool=poi]")
    await click_map(console, 8.0, 8.0)
    dialog = page.locator("#poi-dialog")
    await dialog.locator("input[name=name]").fill("lobby")
    await dialog.locator("input[name=remarks]").fill("second one")
    await dialog.locator("#poi-save").click()
    assert await dialog.is_visible()
    assert "exists already" in await dialog.locator(".form-error").text_content()
    assert await dialog.locator("input[name=name]").input_value() == "lobby"
    assert await dialog.locator("input[name=remarks]").input_value() == "second one"
    await dialog.locator("input[name=name]").fill("lobby 2")
    await dialog.locator("#poi-save").click()
    await page.locator('#poi-list li[data-name="lobby 2"]').wait_for()


async def test_poi_go_is_followed_and_can_be_cancelled(console: Console, watcher):
    page = console.page
    grid = await grid_map(watcher)
    px, py = grid.nearest_clear(20.0, 8.0)
    await add_poi(watcher, "far end", px, py)
    item = page.locator('#poi-list li[data-name="far end"]')
    await item.wait_for()
    await item.locator("button.go").click()
    await page.locator("#goal-status", has_text="m to go").wait_for()
    assert await page.get_attribute("#goal-status", "data-status") == "active"
    await page.click("#cancel-goal")
    await console.wait_data("#goal-status", "status", "preempted")
    assert await page.locator("#cancel-goal").is_disabled()


async def test_topic_inspector_publishes_what_another_client_receives(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/inspector_demo", "std_msgs/String")
    await console.tab("inspect")
    await page.click("#topics-refresh")
    await page.fill("#topic-filter", "inspector_demo")
    await page.click('#topic-list li[data-topic="/inspector_demo"]')
    assert await page.text_content("#topic-detail .topic-type") == "std_msgs/String"
    await page.click("#publish-box summary")
    field = page.locator("#publish-form input[name=data]")
    await field.wait_for()
    await field.fill("hello from the inspector")
    await page.click("#publish-send")
    msg = await watcher.until(lambda: watcher.latest("/inspector_demo"), 10, "the message")
    assert msg == {"data": "hello from the inspector"}
    # the page's own subscription saw it too: count and last message
    await page.locator("#topic-last", has_text="hello from the inspector").wait_for()
    await page.click("#publish-box summary")  # fold the form away again

    # a numeric field of a live topic, plotted while the robot drives
    await simple_goal(watcher, 14.0, 8.0)
    await page.fill("#topic-filter", "odom")
    await page.click(f'#topic-list li[data-topic="{ODOM}"]')
    pick = page.locator("#topic-detail select.plot-pick")
    await page.wait_for_function(
        "() => document.querySelectorAll('select.plot-pick option').length > 3")
    await pick.select_option("pose.pose.position.x")
    await page.wait_for_function(
        "() => Number(document.getElementById('plot-range').dataset.samples) >= 40", timeout=10_000)
    rate = await page.text_content("#topic-rate")
    assert "Hz" in rate and not rate.startswith("0.0")
    await console.snapshot("console-inspector")


async def test_top_bar_fits_on_one_line_at_1280_px(console: Console):
    page = console.page
    await page.set_viewport_size({"width": 1280, "height": 800})
    await console.frame()
    boxes = await page.evaluate("""() => [...document.querySelectorAll(
        '.topbar .brand, .topbar .pill')].filter(e => getComputedStyle(e).display !== 'none')
        .map(e => e.getBoundingClientRect().toJSON())""")  # shown ones (not the state alarm)
    centres = [b["y"] + b["height"] / 2 for b in boxes]
    assert max(centres) - min(centres) < 2, boxes  # one row
    assert max(b["x"] + b["width"] for b in boxes) <= 1280
    assert (await page.locator(".topbar").bounding_box())["height"] < 50
    scale = await page.get_attribute("#scalebar", "data-metres")
    assert float(scale) > 0


async def test_no_go_area_and_erase_change_the_map(console: Console, watcher):
    page = console.page
    grid = await grid_map(watcher)
    x0, y0 = grid.nearest_clear(3.0, 12.5, radius=0.8)
    corner_a, corner_b = (x0 - 0.5, y0 - 0.5), (x0 + 0.5, y0 + 0.5)
    await console.tab("map")
    await page.click("[data-tool=area]")
    await console.drag(await console.to_client(*corner_a), await console.to_client(*corner_b))
    centre = grid.cell(x0, y0)

    def cell_value() -> int | None:
        msg = watcher.latest("/map")
        return None if msg is None else GridMap(msg).cells[centre]

    await watcher.until(lambda: cell_value() == 100, 10, "the no-go area on /map")
    await page.click("[data-tool=erase]")
    await console.drag(await console.to_client(*corner_a), await console.to_client(*corner_b))
    await watcher.until(lambda: cell_value() == 0, 10, "the area erased from /map")
    assert console.errors == []


async def test_graph_and_costmap_overlays_are_drawn(console: Console, watcher):
    page = console.page
    nodes = [{"id": 1, "x": 5.0, "y": 8.0, "z": 0.0}, {"id": 2, "x": 12.0, "y": 8.0, "z": 0.0},
             {"id": 3, "x": 12.0, "y": 12.0, "z": 0.0}]
    edges = [{"from_node": 1, "to_node": 2, "cost": 0.0},
             {"from_node": 2, "to_node": 3, "cost": 0.0}]
    reply = await watcher.call("/save_graph_file", {"name": "demo", "nodes": nodes, "edges": edges})
    assert reply["values"]["success"], reply
    await page.wait_for_function(
        "() => (window.hitrobot.layers.graph.graph || {nodes: []}).nodes.length === 3")
    await console.frame()
    img = await console.screenshot_array()
    x, y = await console.to_client(12.0, 10.0)  # on the edge 2–3
    patch = img[int(y) - 3:int(y) + 4, int(x) - 3:int(x) + 4]
    assert (np.linalg.norm(patch - np.array([0xB3, 0x88, 0xFF]), axis=2) < 60).any()

    # the costmap, computed in the page from /map: a wall cell is lethal, open floor is not
    await console.tab("map")
    await page.check("[data-layer=costmap]")
    await page.wait_for_function("() => Boolean(window.hitrobot.layers.costmap.cells)")
    grid = await grid_map(watcher)
    wall = grid.interior(100, 1)[0]
    fx, fy = grid.nearest_clear(5.0, 8.0, radius=0.7)
    free = grid.cell(fx, fy)
    dist = await page.evaluate("""([a, b]) => { const c = window.hitrobot.layers.costmap.cells;
        return [c.dist[a[0] * c.w + a[1]], c.dist[b[0] * c.w + b[1]], c.lethal]; }""",
                               [[int(wall[0]), int(wall[1])], [free[0], free[1]]])
    assert dist[0] == 0 and dist[1] > dist[2]
    assert console.errors == []


async def test_missing_libraries_show_in_the_bridge_pill(make_server, browser, tmp_path,
                                                         monkeypatch):
    """A pip install without `npm ci --prefix web`: the page, none of its libraries."""
    root = tmp_path / "web"
    root.mkdir()
    for pattern in ("*.html", "*.js", "*.css", "*.svg"):
        for f in (REPO / "web").glob(pattern):
            shutil.copy(f, root / f.name)
    monkeypatch.setattr("hitrobot_server.server.default_web_root", lambda: root)
    server = await make_server()
    page = browser.pages[0] if browser.pages else await browser.new_page()
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.wait_for_function(
        "() => document.getElementById('bridge-state').dataset.state === 'broken'", timeout=10_000)
    text = await page.text_content("#bridge-state .value")
    assert "libraries missing" in text and "npm ci --prefix web" in text
    assert "npm ci --prefix web" in await page.text_content("#hint")


async def test_mapping_view_refits_as_the_map_grows(make_server, browser, tmp_path):
    server = await make_server(robot="sim", sim_speed=4, sim_mapping=True,
                               map_dir=str(tmp_path / "maps"))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    await page.goto(f"http://127.0.0.1:{server.port}/")
    await page.wait_for_function("() => window.hitrobot && window.hitrobot.view.mapBounds",
                                 timeout=30_000)
    first = await page.evaluate("({...window.hitrobot.view.mapBounds})")
    watcher = await Watcher.open(server.port)
    try:
        # drive down the corridor: the robot maps as it goes
        await simple_goal(watcher, 16.0, 8.0)
        await page.wait_for_function("""(b) => { const m = window.hitrobot.view.mapBounds;
            return m.x + m.w > b.x + b.w + 2; }  // metres""", arg=first, timeout=60_000)
    finally:
        await watcher.close()
    # the whole grown map is in view, not just the part seen at the start
    await page.wait_for_function("""(b) => { const v = window.hitrobot.view, m = v.mapBounds;
        const r = v.canvas.getBoundingClientRect();
        const a = v.rosToClient(m.x, m.y), c = v.rosToClient(m.x + m.w, m.y + m.h);
        return [a, c].every(p => p.x >= r.left - 1 && p.x <= r.right + 1 && p.y >= r.top - 1
                                 && p.y <= r.bottom + 1); }""", arg=first, timeout=5_000)


async def test_a_failed_goal_gives_one_toast(console: Console, watcher):
    """A goal inside a piece of furniture: the robot cannot get there. The failure is reported
    once, however many messages describe it (since issue 46 the console refuses it at once, by
    the POIs' placement rule, instead of the planner's "no path" after the drive)."""
    page = console.page
    grid = await grid_map(watcher)
    row, col = grid.interior(100, 3)[0]
    x, y = grid.centre(row, col)
    await page.click("[data-tool=goal]")
    await click_map(console, x, y)
    await page.wait_for_function("""() => ['aborted', 'rejected'].includes(
        document.getElementById('goal-status').dataset.status)""", timeout=20_000)
    await page.locator("#log li.error").first.wait_for()
    await console.frame()
    assert await page.locator(".toast").count() == 1
    assert "goal refused: this spot is on an obstacle" in await page.text_content(".toast")

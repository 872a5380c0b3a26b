"""What surprised a new operator (issue 26), in a real browser against the simulator: Enter
confirms a dialog and Esc cancels it, Esc leaves a tool, Relocalize raises no developer toast,
the Messages panel speaks the operator's language."""

from __future__ import annotations

import socket

from tests.helpers import ServerProcess, Watcher
from tests.web.conftest import Console, add_poi, grid_map


def named(watcher, name: str):
    pois = (watcher.latest("/map_manager/pois") or {}).get("pois", [])
    return next((p for p in pois if p["name"] == name), None)


async def test_enter_confirms_a_dialog_and_escape_cancels_it(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/map_manager/pois", "map_messages/PointsOfInterest")
    grid = await grid_map(watcher)
    spot = await console.to_client(*grid.nearest_clear(3.0, 13.0))
    dialog = page.locator("#poi-dialog")
    name = dialog.locator("input[name=name]")

    # Add POI: typed, then Enter in the remarks field saves it
    await page.click("[data-tool=poi]")
    await page.mouse.click(*spot)
    await name.fill("window seat")
    await dialog.locator("input[name=remarks]").fill("sunny")
    await dialog.locator("input[name=remarks]").press("Enter")
    await dialog.wait_for(state="hidden")
    poi = await watcher.until(lambda: named(watcher, "window seat"), 10, "the POI saved by Enter")
    assert poi["remarks"] == "sunny"
    item = page.locator('#poi-list li[data-name="window seat"]')
    await item.wait_for()

    # Rename: Enter in the name field renames
    await item.locator("button.rename").click()
    await name.fill("reading corner")
    await name.press("Enter")
    await watcher.until(lambda: named(watcher, "reading corner"), 10, "the rename by Enter")

    # a name already taken: Enter keeps the dialog open with the reason and the input
    await page.click("[data-tool=poi]")
    await page.mouse.click(*spot)
    await name.fill("reading corner")
    await name.press("Enter")
    assert "exists already" in await dialog.locator(".form-error").text_content()
    assert await dialog.is_visible() and await name.input_value() == "reading corner"

    # Esc cancels: nothing is added
    await name.fill("never added")
    await name.press("Escape")
    await dialog.wait_for(state="hidden")
    pois_before = (watcher.latest("/map_manager/pois") or {}).get("pois", [])
    # a round trip through the server: another client's POI arrives after anything the page sent
    await add_poi(watcher, "marker", 1.0, 1.0)
    await watcher.until(lambda: named(watcher, "marker"), 10, "the marker POI")
    assert not named(watcher, "never added")
    assert len(watcher.latest("/map_manager/pois")["pois"]) == len(pois_before) + 1

    # Save as: Enter saves a new name at once (one question, not two)
    await console.tab("map")
    await page.click("#map-save-as")
    names = page.locator("#name-dialog")
    await names.locator("input[name=name]").fill("by_enter")
    await names.locator("input[name=name]").press("Enter")
    await page.locator('#map-list li[data-name="by_enter"]').wait_for(timeout=15_000)
    assert not await page.locator("#confirm-dialog").is_visible()
    assert (console.server.settings.store.map_store / "by_enter" / "map.yaml").is_file()
    assert console.errors == []


async def test_escape_leaves_the_waypoint_tool(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/planning/patrol_state", "hitrobot_msgs/PatrolState")
    await page.click("[data-tool=waypoint]")
    assert "Esc" in await page.text_content("#hint")
    await page.mouse.click(*(await console.to_client(11.0, 8.0)))
    await page.locator("#waypoint-list li").first.wait_for()
    await page.keyboard.press("Escape")
    assert await page.evaluate("() => window.hitrobot.tools.tool") == "move"
    assert "active" in (await page.get_attribute("[data-tool=move]", "class") or "")
    assert "active" not in (await page.get_attribute("[data-tool=waypoint]", "class") or "")
    assert await page.evaluate("() => window.hitrobot.view.canvas.dataset.cursor") == "move"
    assert "Drag to pan" in await page.text_content("#hint")
    assert await page.locator("#waypoint-list li").count() == 1


async def test_relocalize_sends_a_complete_request_and_raises_no_toast(console: Console):
    page = console.page
    await page.click("#relocalize")
    # the robot's own answer to this request is the round trip that ends the test
    # in the operator's words: "relocalization: done", not the request's raw name
    await page.locator("#log li", has_text="relocalization: done").wait_for(timeout=60_000)
    assert await page.locator("#log li.warning").count() == 0
    assert await page.locator("#toasts .toast").count() == 0
    texts = await page.locator("#log li .text").all_text_contents()
    assert not [t for t in texts if "lacks field" in t or "publish to" in t or "(publish:" in t
                or t.startswith("recover_localization")]
    assert console.errors == []


async def test_navigation_panel_follows_go_home_and_can_cancel_it(console: Console, watcher):
    page = console.page
    status = page.locator("#goal-status")
    # a goal of the page's own first, then Go home replaces it: the panel follows the new motion
    await page.evaluate("window.hitrobot.navigator.sendGoal(11, 8, 0)")
    await console.wait_data("#goal-status", "status", "active", timeout=20)
    await page.click("#go-home")
    await status.locator("text=home").wait_for()
    await page.locator("#goal-status", has_text="m to go").wait_for(timeout=20_000)
    assert await status.get_attribute("data-status") == "active"
    assert "home" in await status.text_content()
    assert await page.locator("#cancel-goal").is_enabled()
    await page.click("#cancel-goal")
    await console.wait_data("#goal-status", "status", "preempted", timeout=20)
    assert "home" in await status.text_content()
    assert await page.locator("#cancel-goal").is_disabled()
    assert console.errors == []


async def test_navigation_panel_follows_a_patrol_and_cancel_stops_it(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/planning/patrol_state", "hitrobot_msgs/PatrolState")
    await page.click("[data-tool=waypoint]")
    for i, (x, y) in enumerate([(11.0, 8.0), (7.0, 8.6)], 1):
        await page.mouse.click(*(await console.to_client(x, y)))
        await page.locator("#waypoint-list li").nth(i - 1).wait_for()
    await page.keyboard.press("Escape")
    await page.click("#patrol-start")
    status = page.locator("#goal-status")
    await page.locator("#goal-status", has_text="waypoint 1 of 2").wait_for(timeout=20_000)
    await page.locator("#goal-status", has_text="m to go").wait_for(timeout=20_000)
    assert await status.get_attribute("data-status") == "active"
    assert await page.locator("#cancel-goal").is_enabled()
    await page.click("#cancel-goal")
    await watcher.until(lambda: (s := watcher.latest("/planning/patrol_state"))
                        and not s["active"], 20, "the patrol stopped by Cancel")
    await page.locator("#goal-status", has_text="Patrol stopped").wait_for()
    assert await page.locator("#cancel-goal").is_disabled()
    assert console.errors == []


async def open_page(browser, port: int) -> Console:
    page = browser.pages[0] if browser.pages else await browser.new_page()
    result = Console(page, None)
    page.on("console", lambda m: result.errors.append(f"console.{m.type}: {m.text}")
            if m.type == "error" else None)
    page.on("pageerror", lambda e: result.errors.append(f"page error: {e}"))
    await page.goto(f"http://127.0.0.1:{port}/")
    return result


async def robot_controls_disabled(page) -> dict[str, bool]:
    return await page.evaluate("""() => Object.fromEntries(
        ['go-home', 'relocalize', 'stop-motion', 'patrol-start', 'map-save-as', 'clear-walls']
          .map((id) => [id, document.getElementById(id).disabled])
          .concat([...document.querySelectorAll('[data-tool]:not([data-tool=move])')]
            .map((b) => [b.dataset.tool, b.disabled])))""")


async def test_no_robot_says_so_and_disables_robot_actions(make_server, browser, tmp_path):
    server = await make_server(robot="none", map_dir=str(tmp_path / "maps"))
    console = await open_page(browser, server.port)
    page = console.page
    await page.locator("#robot-state .value", has_text="no robot").wait_for(timeout=20_000)
    assert await page.get_attribute("#robot-state", "data-state") == "none"
    assert "No robot" in await page.text_content("#hint")
    assert "Waiting for the map" not in await page.text_content("#hint")
    assert await page.text_content("#goal-status") == "No robot"
    disabled = await robot_controls_disabled(page)
    assert disabled and all(disabled.values()), disabled
    # the inspector still works without a robot
    await page.click(".tabs [data-tab=inspect]")
    assert await page.locator("#topic-filter").is_enabled()
    texts = await page.locator("#log li .text").all_text_contents()
    assert not [t for t in texts if "going home" in t]
    assert console.errors == []


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def robot_server(port: int, map_dir) -> ServerProcess:
    return ServerProcess("--bus", "zenoh", "--zenoh-listen", f"tcp/127.0.0.1:{port}",
                         "--sim-speed", "4", "--map-dir", str(map_dir), "--log-level",
                         "warning", robot="sim")


async def test_robot_offline_on_zenoh_then_back(browser, tmp_path):
    """Server A holds the robot, the page is on B (--robot none): A dies → B's page says
    "robot offline" and disables robot actions; A back → the page starts over with it."""
    port = free_port()
    a = robot_server(port, tmp_path / "maps")
    b = ServerProcess("--bus", "zenoh", "--zenoh-connect", f"tcp/127.0.0.1:{port}",
                      "--log-level", "warning")
    try:
        console = await open_page(browser, b.port)
        page = console.page
        present = """() => window.hitrobot && window.hitrobot.presence.present === true &&
            window.hitrobot.state.pose !== null"""
        await page.wait_for_function(present, timeout=30_000)
        assert not (await robot_controls_disabled(page))["go-home"]

        a.proc.kill()  # kill -9: only Zenoh's liveliness tells B
        a.proc.wait(10)
        await page.locator("#robot-state .value", has_text="offline").wait_for(timeout=30_000)
        assert "Robot offline" in await page.text_content("#hint")
        assert (await page.text_content("#goal-status")).startswith("ROBOT OFFLINE")
        disabled = await robot_controls_disabled(page)
        assert all(disabled.values()), disabled
        assert await page.evaluate("() => document.body.classList.contains('no-robot')")

        await page.evaluate("() => { window.beforeReturn = true; }")
        a = robot_server(port, tmp_path / "maps")
        # the page reloads itself (a fresh page has no mark) and follows the robot again
        await page.wait_for_function(
            f"() => window.beforeReturn === undefined && ({present})()", timeout=60_000)
        assert not (await robot_controls_disabled(page))["go-home"]
        assert await page.get_attribute("#robot-state", "data-state") != "none"
        w = await Watcher.open(a.port)
        try:
            await add_poi(w, "after the return", 3.0, 13.0)
            await page.locator('#poi-list li[data-name="after the return"]').wait_for(
                timeout=20_000)
        finally:
            await w.close()
    finally:
        b.stop()
        a.stop()


async def test_layout_messages_in_view_pills_wrap_map_refits(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/planning/patrol_state", "hitrobot_msgs/PatrolState")
    # 1440 × 900: the Messages panel is on screen beside the Operate tab
    box = await page.locator("#log").bounding_box()
    assert box["y"] + 40 < 900 and box["height"] >= 80, box

    # "1 wall", not "1 walls"
    await console.tab("map")
    await watcher.publish("/slamware_ros_sdk_server_node/add_line", {
        "usage": {"usage": 0}, "line": {"id": 0, "start": {"x": 18.0, "y": 1.6},
                                         "end": {"x": 22.5, "y": 1.6}}},
        "slamware_ros_sdk/AddLineRequest")
    await page.locator("#line-counts", has_text="1 wall ·").wait_for(timeout=10_000)
    assert "0 tracks" in await page.text_content("#line-counts")

    # the map is fitted again when the window changes size
    async def map_fits() -> bool:
        corners = await page.evaluate("""() => {
            const v = window.hitrobot.view, b = v.mapBounds;  // as fit() reads them
            return [v.rosToClient(b.x, b.y), v.rosToClient(b.x + b.w, b.y + b.h)]; }""")
        rect = await page.locator("#map").bounding_box()
        return all(rect["x"] - 1 <= c["x"] <= rect["x"] + rect["width"] + 1
                   and rect["y"] - 1 <= c["y"] <= rect["y"] + rect["height"] + 1
                   for c in corners)

    assert await map_fits()
    await page.set_viewport_size({"width": 960, "height": 700})
    await page.wait_for_function("""() => { const v = window.hitrobot.view;
        const dpr = window.devicePixelRatio || 1;
        return v.canvas.width === Math.round(v.container.clientWidth * dpr); }""")
    await console.frame()
    assert await map_fits()

    # under ~1000 px the header pills wrap instead of being cut off
    # (a pill hidden by design, e.g. the state-saving alarm while all is well, is not drawn)
    pills = await page.evaluate("""() => [...document.querySelectorAll('.topbar .pill')]
        .filter((e) => getComputedStyle(e).display !== 'none')
        .map((e) => ({ right: e.getBoundingClientRect().right, visible: e.checkVisibility() }))""")
    assert pills and all(p["visible"] and p["right"] <= 960 for p in pills), pills
    assert console.errors == []


async def test_the_dock_is_drawn_where_the_map_manager_says(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/map_manager/home", "geometry_msgs/PoseStamped")
    home = await watcher.until(lambda: watcher.latest("/map_manager/home"), 10, "the dock")
    drawn = await page.wait_for_function("""() => {
        const d = window.hitrobot.layers.dock;
        return d.pose && d.node.children.length === 1 && d.node.visible &&
          { x: d.node.children[0].x, y: -d.node.children[0].y }; }""", timeout=10_000)
    at = await drawn.json_value()
    p = home["pose"]["position"]
    assert abs(at["x"] - p["x"]) < 1e-6 and abs(at["y"] - p["y"]) < 1e-6
    await console.snapshot("console-dock")


async def test_the_plot_has_axes(console: Console):
    page = console.page
    odom = "/slamware_ros_sdk_server_node/odom"
    await console.tab("inspect")
    await page.click("#topics-refresh")
    await page.fill("#topic-filter", "odom")
    await page.click(f'#topic-list li[data-topic="{odom}"]')
    await page.wait_for_function(
        "() => document.querySelectorAll('select.plot-pick option').length > 3")
    await page.locator("#topic-detail select.plot-pick").select_option("pose.pose.position.x")
    await page.wait_for_function(
        "() => Number(document.getElementById('plot-range').dataset.samples) >= 30",
        timeout=15_000)
    ticks = await page.evaluate("""() => { const d = document.getElementById('plot').dataset;
        return { y: d.yTicks.split(',').map(Number), t: d.tTicks.split(',').map(Number) }; }""")
    x = (await page.evaluate("() => window.hitrobot.state.pose.x"))
    assert len(ticks["y"]) >= 2 and min(ticks["y"]) <= x + 1 and max(ticks["y"]) >= x - 1
    assert ticks["t"][0] == 0 and len(ticks["t"]) >= 2 and all(t <= 0 for t in ticks["t"])
    await console.snapshot("console-plot")
    assert console.errors == []


async def test_a_poi_added_in_the_page_logs_one_friendly_line(console: Console, watcher):
    page = console.page
    await watcher.subscribe("/map_manager/pois", "map_messages/PointsOfInterest")
    grid = await grid_map(watcher)
    await page.click("[data-tool=poi]")
    await page.mouse.click(*(await console.to_client(*grid.nearest_clear(3.0, 13.0))))
    await page.locator("#poi-dialog input[name=name]").fill("lobby")
    await page.locator("#poi-dialog input[name=name]").press("Enter")
    await page.locator("#log li", has_text="POI “lobby” added").wait_for(timeout=10_000)
    texts = await page.locator("#log li .text").all_text_contents()
    assert [t for t in texts if "lobby" in t] == [next(t for t in texts if "added at" in t)]
    assert not [t for t in texts if "publish" in t or "add_poi" in t]


async def test_navigation_panel_follows_a_motion_sent_by_another_client(console: Console,
                                                                        watcher):
    page = console.page
    await watcher.publish("/move_base_simple/goal", {
        "header": {"frame_id": "map"},
        "pose": {"position": {"x": 11.0, "y": 8.0, "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
        "geometry_msgs/PoseStamped")
    await page.locator("#goal-status", has_text="sent elsewhere").wait_for(timeout=20_000)
    await page.locator("#goal-status", has_text="m to go").wait_for(timeout=20_000)
    assert await page.get_attribute("#goal-status", "data-status") == "active"
    assert await page.locator("#cancel-goal").is_enabled()
    await page.click("#cancel-goal")
    await page.locator("#goal-status", has_text="the robot stopped").wait_for(timeout=20_000)
    assert await page.locator("#cancel-goal").is_disabled()
    assert console.errors == []

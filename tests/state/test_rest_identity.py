"""A real robot over REST (a ``sim-device`` that keeps running while the server restarts):
the server's own state is kept per robot identity (device id), two robots never share it,
and the log says which side's state won."""

from __future__ import annotations

from hitrobot_server.robot.device import SimDevice
from hitrobot_server.robot.factory import build_simulator
from tests.helpers import ServerProcess, Watcher
from tests.nodes.map_manager.util import BLOCKED, MM, NS, cell, modify_map, poi, rect, request
from tests.state.test_restart import WALL, diagnostic, line, lines_of

POI_T = "map_messages/PointOfInterest"
MASK = (8.0, 3.0, 8.6, 3.6)


async def device(seed: int) -> SimDevice:
    dev = SimDevice(build_simulator(None, seed), port=0, time_scale=4.0)
    await dev.start()
    return dev


async def bound(port: int) -> Watcher:
    """A watcher once the server knows the robot's identity (its state entry is published)."""
    w = await Watcher.open(port)
    await w.client.send({"op": "set_level", "level": "info"})
    for topic in ("/diagnostics_agg", "/map", f"{NS}/virtual_walls"):
        await w.subscribe(topic)
    await w.until(lambda: diagnostic(w, "/Bridge/State"), 20, "the robot's state folder")
    return w


async def pois(w: Watcher) -> list[str]:
    return [p["name"] for p in (await w.call(f"{MM}/get_pois"))["values"]["poi_list"]["pois"]]


async def test_the_servers_state_follows_the_robots_identity(tmp_path):
    state = tmp_path / "state"
    args = ("--state-dir", str(state), "--map-dir", str(tmp_path / "maps"))
    one, two = await device(1), await device(2)
    ident = "slamware-" + one.simulator.device_info().device_id
    try:
        first = ServerProcess(*args, robot=one.url)
        try:
            w = await bound(first.port)
            assert diagnostic(w, "/Bridge/State")["message"] == \
                f"started fresh in {state / ident}"
            assert (await request(w, f"{MM}/add_poi", POI_T, poi("dock", 3.0, 8.0), "p")
                    )["level"] == "info"
            assert (await modify_map(w, "m", rect(*MASK), BLOCKED))["level"] == "info"
            await w.publish(f"{NS}/add_line", {"usage": {"usage": 0}, "line": line(1, WALL)},
                            "slamware_ros_sdk/AddLineRequest")
            await w.until(lambda: lines_of(w, "virtual_walls"), 10, "the robot's wall")
            await w.close()
        finally:
            first.kill()

        # the device kept running; a new server on the same folder finds robot one's state
        second = ServerProcess(*args, robot=one.url)
        try:
            restored = (await bound(second.port))
            assert await pois(restored) == ["dock"]
            x, y = (MASK[0] + MASK[2]) / 2, (MASK[1] + MASK[3]) / 2
            await restored.until(lambda: (grid := restored.latest("/map")) is not None
                                 and cell(grid, x, y) == BLOCKED, 10,
                                 "the mask back")
            # the wall is the robot's own: it kept it, the server did not push it
            await restored.until(lambda: lines_of(restored, "virtual_walls"), 10, "the wall")
            assert diagnostic(restored, "/Bridge/State")["message"] == \
                f"state restored from {state / ident}"
            await restored.close()
        finally:
            second.stop()

        # robot two on the same folder root: its own, empty state; robot one's untouched
        third = ServerProcess(*args, robot=two.url)
        try:
            w = await bound(third.port)
            assert await pois(w) == []
            assert "started fresh in" in diagnostic(w, "/Bridge/State")["message"]
            await w.close()
        finally:
            third.stop()
        folders = sorted(p.name for p in state.iterdir())
        assert len(folders) == 2 and ident in folders
    finally:
        await one.stop()
        await two.stop()


async def test_which_side_wins_when_the_robot_is_reached_late_or_swapped(make_server, tmp_path,
                                                                         caplog):
    """Changes made before the robot is reached are newer than its folder: the server's side
    wins (the folder's snapshot is kept aside). Another robot at the same address: its own
    folder wins and the first robot's stays as it was."""
    import logging

    caplog.set_level(logging.INFO, logger="hitrobot_server")
    state = tmp_path / "state"
    one = await device(1)
    port = one.port
    await one.stop()  # the robot is not reachable when the server starts
    server = await make_server(robot=f"http://127.0.0.1:{port}", state_dir=str(state),
                               map_dir=str(tmp_path / "maps"))
    w = await Watcher.open(server.port)
    await w.client.send({"op": "set_level", "level": "info"})
    assert (await request(w, f"{MM}/add_poi", POI_T, poi("early", 1.0, 8.0), "p"))[
        "level"] == "info"
    one = SimDevice(build_simulator(None, 1), port=port, time_scale=4.0)
    await one.start()
    await w.until(lambda: "the server's state won" in caplog.text, 20, "the binding")
    assert "not reached yet" in caplog.text
    ident_one = "slamware-" + one.simulator.device_info().device_id
    await server.state.store.flush()
    assert server.state.identity == ident_one and server.state.store.get(
        "map_manager/pois")[0]["name"] == "early"

    await one.stop()
    two = SimDevice(build_simulator(None, 2), port=port, time_scale=4.0)
    await two.start()
    try:
        await w.until(lambda: "a different robot" in caplog.text, 20, "robot two")
        assert await pois(w) == []  # robot two's own (empty) state
        assert (state / ident_one).is_dir() and server.state.identity != ident_one
    finally:
        await w.close()
        await server.stop()
        await two.stop()

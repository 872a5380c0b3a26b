"""One driver at a time (issue 47 item 4) and a stop that never cancels another's goal (issue
46), with real clients on a real server: rosbridge over WebSocket and raw TCP, roslibpy."""

from __future__ import annotations

import asyncio
import time

import pytest
import roslibpy

from hitrobot_server.robot.device import SimDevice
from hitrobot_server.robot.factory import build_simulator
from hitrobot_server.robot.rest import paths
from hitrobot_server.state.tokens import add_token
from tests.helpers import TcpClient, Watcher, connect_roslibpy

NS = "/slamware_ros_sdk_server_node"
TWIST = "geometry_msgs/Twist"
LEASE = "/drive_lease"


def twist(x: float = 0.0, z: float = 0.0) -> dict:
    return {"linear": {"x": x, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": z}}


def zeros(w: Watcher, after: float = 0.0) -> list[float]:
    """When the watcher got each zero /cmd_vel (after ``after``)."""
    return [t for t, m in w.messages.get("/cmd_vel", [])
            if t > after and m["linear"]["x"] == 0 and m["angular"]["z"] == 0]


def lease(w: Watcher) -> dict:
    return w.latest(LEASE) or {}


async def watching(port: int) -> Watcher:
    w = await Watcher.open(port)
    await w.subscribe("/cmd_vel", TWIST)
    await w.subscribe(LEASE)
    await w.until(lambda: LEASE in w.messages, 5, "the latched lease")
    return w


async def settled(w: Watcher) -> None:
    """A round trip of the watcher: what the server sent it before is in."""
    await w.call("/rosapi/get_time")


async def test_one_driver_at_a_time_and_the_lease_lapses_with_one_stop(make_server):
    server = await make_server(robot="sim")
    w = await watching(server.port)
    a = await Watcher.open(server.port)  # A: rosbridge over WebSocket
    b = await TcpClient.open(server.tcp_port)  # B: raw TCP
    try:
        assert lease(w)["holder"] == ""
        await a.publish("/cmd_vel", twist(0.2), TWIST, op_id="a0")
        held = await w.until(lambda: lease(w).get("holder"), 5, "A holding the lease")
        assert held.startswith("/") and lease(w)["reason"] == "took the lease"
        await b.send({"op": "advertise", "topic": "/cmd_vel", "type": TWIST})
        await b.send({"op": "publish", "id": "b1", "topic": "/cmd_vel", "msg": twist(0.0, 0.5)})
        refused = await b.expect(op="status", id="b1")
        assert refused["level"] == "error" and f"driven by {held}" in refused["msg"], refused
        # a stop from B while A drives is refused too (it would interleave with A's commands)
        await b.send({"op": "publish", "id": "b2", "topic": "/cmd_vel", "msg": twist()})
        assert f"driven by {held}" in (await b.expect(op="status", id="b2"))["msg"]
        last = time.monotonic()
        await a.publish("/cmd_vel", twist(0.2), op_id="a1")  # A's last command
        lapsed = await w.until(lambda: lease(w).get("reason") == "lapsed" and lease(w), 5,
                               "the lease lapsing")
        assert lapsed["holder"] == "" and lapsed["previous"] == held and lapsed["stopped"]
        gap = time.monotonic() - last
        assert gap >= 0.45, gap  # not before its time (the watcher's clock, a little late)
        await settled(w)
        assert len(zeros(w, last)) == 1, w.messages["/cmd_vel"]  # exactly one stop
        # now B takes it
        await b.send({"op": "publish", "id": "b3", "topic": "/cmd_vel", "msg": twist(0.0, 0.5)})
        taken = await w.until(lambda: lease(w).get("holder") not in ("", None) and lease(w), 5,
                              "B holding the lease")
        assert taken["holder"] != held and taken["previous"] == ""
        await a.publish("/cmd_vel", twist(0.2), op_id="a2")
        refused = await a.until(lambda: next((s for s in a.statuses if s.get("id") == "a2"),
                                             None), 5, "A refused")
        assert f"driven by {taken['holder']}" in refused["msg"], refused
        assert not [s for s in a.statuses if s.get("id") in ("a0", "a1")]  # A's went through
    finally:
        await b.close()
        await a.close()
        await w.close()


@pytest.mark.serial  # the figure: the stop after a disconnect, measured; run alone
async def test_a_holder_that_disconnects_mid_drive_stops_the_robot_at_once(make_server):
    server = await make_server(robot="sim")
    w = await watching(server.port)
    a = await asyncio.to_thread(connect_roslibpy, server.port)  # A: roslibpy
    try:
        cmd = roslibpy.Topic(a, "/cmd_vel", TWIST)
        await asyncio.to_thread(cmd.advertise)
        for _ in range(5):  # a joystick's 10 Hz, until the lease is A's
            await asyncio.to_thread(cmd.publish, roslibpy.Message(twist(0.3)))
            if lease(w).get("holder"):
                break
            await asyncio.sleep(0.1)  # the drive's own rate, not a synchronisation
        held = await w.until(lambda: lease(w).get("holder"), 5, "A holding the lease")
        await w.until(lambda: w.messages.get("/cmd_vel"), 5, "A's commands on the bus")
    finally:
        closed = time.monotonic()
        await asyncio.to_thread(a.close)
    try:
        stop = await w.until(lambda: zeros(w, closed), 5, "the stop after A left")
        ended = lease(w)
        assert ended["reason"] == "disconnected" and ended["previous"] == held
        assert ended["stopped"] and ended["holder"] == ""
        figure = stop[0] - closed
        print(f"disconnect -> zero command on the bus: {figure * 1000:.1f} ms")
        assert figure < 0.6, figure  # the bound (it is a few ms)
        await settled(w)
        assert len(zeros(w, closed)) == 1
    finally:
        await w.close()


async def test_an_admin_takes_the_lease_over_and_a_user_may_not(make_server, tmp_path):
    tokens = tmp_path / "tokens.json"
    names = (("watcher-1", "operator"), ("user-1", "operator"), ("admin-1", "admin"))
    secrets = [add_token(tokens, name, role, None) for name, role in names]
    server = await make_server(robot="sim", authenticate=True, tokens_file=str(tokens))
    clients = [await Watcher.open(server.port) for _ in range(3)]
    w, user, admin = clients
    drive = asyncio.ensure_future(asyncio.sleep(0))
    try:
        for client, token in zip(clients, secrets, strict=True):  # named tokens, not rosauth
            await client.client.send({"op": "auth", "token": token})
        await w.subscribe("/cmd_vel", TWIST)
        await w.subscribe(LEASE)
        await w.publish("/cmd_vel", twist(0.2), TWIST)  # the watcher drives first, at 10 Hz
        drive = asyncio.ensure_future(joystick(w))
        held = await w.until(lambda: lease(w).get("holder"), 5, "the first driver")
        got = await user.call("/drive_lease/take")
        assert got["result"] and not got["values"]["success"], got
        assert "admin" in got["values"]["message"]
        assert lease(w)["holder"] == held
        start = len(zeros(w))
        got = await admin.call("/drive_lease/take")
        assert got["values"]["success"], got
        taken = await w.until(lambda: lease(w).get("previous") == held and lease(w), 5,
                              "the admin holding the lease")
        drive.cancel()
        await settled(w)
        assert taken["reason"].startswith("taken over by") and taken["stopped"]
        assert taken["holder"] not in ("", held)
        assert len(zeros(w)) == start + 1  # the driver taken over from: one stop
        await admin.publish("/cmd_vel", twist(0.0, 0.4), TWIST, op_id="drive")
        await w.publish("/cmd_vel", twist(0.2), op_id="was-mine")
        refused = await w.until(lambda: next((s for s in w.statuses
                                              if s.get("id") == "was-mine"), None), 5, "refusal")
        assert f"driven by {taken['holder']}" in refused["msg"]
        await settled(admin)
        assert not [s for s in admin.statuses if s.get("id") == "drive"]
    finally:
        drive.cancel()
        for client in clients:
            await client.close()


async def joystick(w: Watcher, topic: str = "/cmd_vel") -> None:
    """Drive at a joystick's 10 Hz until cancelled (bounded: a minute)."""
    for _ in range(600):
        await w.publish(topic, twist(0.2))
        await asyncio.sleep(0.1)  # the drive's own rate, not a synchronisation


async def far_goal(w: Watcher) -> None:
    """A goal across the office that outlives what the test does meanwhile."""
    await w.publish(f"{NS}/move_to", {
        "location": {"x": 20.0, "y": 8.2, "z": 0.0}, "yaw": 0.0,
        "options": {"opt_flags": {"flags": 0}, "speed_ratio": {"is_valid": False, "value": 0.0}},
    }, op_id="goal")
    await w.until(lambda: (w.latest(f"{NS}/odom") or {"twist": {"twist": {"linear": {"x": 0}}}})
                  ["twist"]["twist"]["linear"]["x"] > 0.1, 20, "the robot on its way")


@pytest.fixture
async def devices():
    """Sim-devices a test starts, stopped after its servers (set up before make_server)."""
    started: list[SimDevice] = []
    yield started
    for device in started:
        await device.stop()


async def test_a_stop_from_a_watcher_never_cancels_a_goal(devices, make_server, backend):
    """Run per backend (tests/nodes/conftest.py): in process, and over REST to a sim-device."""
    if backend == "rest":
        devices.append(SimDevice(build_simulator(None, 0, False), port=0, time_scale=4.0))
        await devices[0].start()
    server = await make_server(robot=devices[0].url if devices else "sim", sim_speed=4.0)
    owner = await Watcher.open(server.port)  # started the goal
    watcher = await Watcher.open(server.port)  # only watched, then sends a stop
    try:
        for client in (owner, watcher):  # both hear info statuses (the goal's end, the no-op)
            await client.client.send({"op": "set_level", "level": "info"})
        await owner.subscribe(f"{NS}/odom")
        await far_goal(owner)
        posted = devices[0].hits[paths.ACTIONS] if devices else 0
        await watcher.publish("/cmd_vel", twist(), TWIST, op_id="stop")
        noop = await watcher.until(lambda: next(
            (s for s in watcher.statuses if s.get("id") == "stop"), None), 10, "an answer")
        assert noop["level"] == "info" and "leaves the running MoveToAction alone" in \
            noop["msg"], noop
        if devices:  # no motion command reached the robot: no action posted
            assert devices[0].hits[paths.ACTIONS] == posted
        done = await owner.until(lambda: next(
            (s for s in owner.statuses if s.get("id") == "goal"), None), 90, "the goal")
        assert done["msg"].endswith("move_to: done"), done
    finally:
        await watcher.close()
        await owner.close()


async def test_each_robot_of_a_fleet_has_its_own_lease(make_server, tmp_path):
    from hitrobot_server.robot.options import RobotEntry

    server = await make_server(
        robots=(RobotEntry("a", "sim", (4.0, 8.0, 0.0)), RobotEntry("b", "sim", (12.0, 8.0, 0.0))),
        map_dir=str(tmp_path / "maps"))
    w = await Watcher.open(server.port)
    one, two = await Watcher.open(server.port), await Watcher.open(server.port)
    drive = asyncio.ensure_future(asyncio.sleep(0))
    try:
        for name in ("a", "b"):
            await w.subscribe(f"/{name}/drive_lease")
        await one.publish("/a/cmd_vel", twist(0.0, 0.3), TWIST, op_id="one-a")
        drive = asyncio.ensure_future(joystick(one, "/a/cmd_vel"))  # one keeps driving a
        await two.publish("/b/cmd_vel", twist(0.0, 0.3), TWIST, op_id="two-b")
        holders = await w.until(lambda: all((w.latest(f"/{n}/drive_lease") or {}).get("holder")
                                            for n in "ab") and
                                [w.latest(f"/{n}/drive_lease")["holder"] for n in "ab"], 5,
                                "both robots driven")
        assert holders[0] != holders[1]
        await two.publish("/a/cmd_vel", twist(0.0, 0.3), TWIST, op_id="two-a")
        refused = await two.until(lambda: next((s for s in two.statuses
                                                if s.get("id") == "two-a"), None), 5, "refusal")
        assert f"driven by {holders[0]}" in refused["msg"] and "/a/drive_lease/take" in \
            refused["msg"], refused
        assert not [s for s in one.statuses + two.statuses if s.get("id") in ("one-a", "two-b")]
    finally:
        drive.cancel()
        for client in (w, one, two):
            await client.close()

"""Fleet operations against the real server with two simulated robots: the simulator's controls,
the charging policy, dispatch by cost, pause/resume, out of service, the history and open tasks
across a restart, schedules on a held clock, and the queue's bounds and checked targets."""

from __future__ import annotations

import dataclasses
import math

from hitrobot_server.config import Settings
from hitrobot_server.robot.options import RobotEntry
from hitrobot_server.server import HitrobotServer
from tests.helpers import Watcher
from tests.nodes.fleet.test_node import Y, add_poi, at, dispatch, fleet, pose, robots, task


async def battery(w: Watcher, robot: str, percent: float) -> None:
    reply = await w.call(f"/{robot}/sim/set_battery", {"percent": percent})
    assert reply["values"]["success"], reply
    await w.until(lambda: abs(robots(w)[robot]["battery"] - percent) < 1.5, 5,
                  f"{robot} at {percent} %")


def tasks(w: Watcher) -> list[dict]:
    return (w.latest("/fleet/tasks") or {"tasks": []})["tasks"]


def state(w: Watcher, task_id: int) -> str:
    return (task(w, task_id) or {}).get("state", "")


async def test_sim_controls_battery_kidnap_and_emergency_stop(make_server, tmp_path):
    server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 12.0, Y))
    try:
        await battery(w, "a", 60.0)
        bad = await w.call("/a/sim/set_battery", {"percent": 150.0})
        assert not bad["values"]["success"] and "percent" in bad["values"]["message"]
        assert abs(robots(w)["a"]["battery"] - 60.0) < 1.5
        # kidnapped: the believed pose stays, the scans stop matching, the robot notices
        before = robots(w)["b"]["pose"]["position"]
        turned = {**pose(12.0, 4.0), "orientation": {"x": 0, "y": 0, "z": math.sin(0.6),
                                                     "w": math.cos(0.6)}}
        moved = await w.call("/b/sim/kidnap", {"pose": turned})
        assert moved["values"]["success"], moved
        await w.until(lambda: robots(w)["b"]["state"] == "error"
                      and "localization" in robots(w)["b"]["message"], 10,
                      "b noticing it is lost")
        now = robots(w)["b"]["pose"]["position"]
        assert abs(now["x"] - before["x"]) < 0.3 and abs(now["y"] - before["y"]) < 0.3
        wall = await w.call("/b/sim/kidnap", {"pose": pose(-0.4, -0.4)})
        assert not wall["values"]["success"] and "free floor" in wall["values"]["message"]
        # the emergency stop: a FATAL health error, on the robot's diagnostics and the fleet
        await w.subscribe("/a/diagnostics_agg")
        pressed = await w.call("/a/sim/emergency_stop", {"data": True})
        assert pressed["values"]["success"], pressed
        await w.until(lambda: robots(w)["a"]["message"] == "emergency stop pressed", 5,
                      "the fleet seeing the stop")
        await w.until(lambda: any("emergency stop pressed" in s["message"] for s in (
            w.latest("/a/diagnostics_agg") or {"status": []})["status"]), 5,
            "/a/diagnostics_agg reporting it")
        refused = await dispatch(w, target=pose(6.0, Y), robot="a")
        assert refused["accepted"] and refused["robot"] == ""  # queued: a is not free
        assert state(w, refused["task"]) == "queued"
        await w.call("/a/sim/emergency_stop", {"data": False})
        await w.until(lambda: state(w, refused["task"]) == "succeeded", 30,
                      "a running it once released")
    finally:
        await w.close()
    single = await make_server(robot="sim", sim_speed=4.0)
    s = await Watcher.open(single.port)
    try:
        reply = await s.call("/sim/set_battery", {"percent": 42.0})
        assert reply["values"] == {"success": True, "message": "battery at 42.0 %"}
    finally:
        await s.close()
    assert server.port != single.port


async def test_sim_kidnap_refuses_a_zero_or_non_normalisable_quaternion(make_server):
    server = await make_server(robot="sim")
    w = await Watcher.open(server.port)
    try:
        before = server.robot.simulator.true_pose
        for q in ({"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0},
                  {"x": 1e-300, "y": 0.0, "z": 0.0, "w": 0.0},
                  {"x": 1e308, "y": 1e308, "z": 1e308, "w": 1e308}):
            reply = await w.call("/sim/kidnap", {"pose": {**pose(5.0, 8.0), "orientation": q}})
            assert not reply["values"]["success"], (q, reply)
            assert "pose.orientation" in reply["values"]["message"]
            assert "quaternion" in reply["values"]["message"]
            assert server.robot.simulator.true_pose == before  # refused: nothing moved
        unnormalised = {"x": 0.0, "y": 0.0, "z": 2.0, "w": 0.0}  # a half turn, length 2
        moved = await w.call("/sim/kidnap", {"pose": {**pose(before.x + 0.5, before.y),
                                                      "orientation": unnormalised}})
        assert moved["values"]["success"], moved
        assert abs(abs(server.robot.simulator.true_pose.yaw) - math.pi) < 1e-6
    finally:
        await w.close()


async def test_a_low_robot_charges_on_its_own_and_new_work_goes_to_the_other(make_server,
                                                                             tmp_path):
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 14.0, Y), speed=4.0)
    try:
        await battery(w, "a", 20.0)
        await w.until(lambda: any(t["kind"] == "charge" and t["robot"] == "a"
                                  and t["state"] == "running" for t in tasks(w)), 5,
                      "a sent to charge")
        charge = next(t for t in tasks(w) if t["kind"] == "charge")
        assert "below 25 %" in charge["message"] or "charge" in charge["message"]
        got = await dispatch(w, target=pose(5.0, Y))  # next to a, but a is charging
        assert got["accepted"] and got["robot"] == "b", got
        assert "a " in got["message"] and "charges first" not in got["message"].split(";")[0]
        await w.until(lambda: robots(w)["a"]["state"] == "charging", 40, "a on its dock")
        await battery(w, "a", 95.0)
        await w.until(lambda: state(w, charge["id"]) == "succeeded", 10, "a charged")
        done = task(w, charge["id"])
        assert done["created"] <= done["started"] <= done["finished"] and done["finished"] > 0
        await w.until(lambda: state(w, got["task"]) == "succeeded", 40, "b arriving")
    finally:
        await w.close()


async def test_a_task_does_not_queue_behind_a_charge_while_another_robot_is_idle(make_server,
                                                                                tmp_path):
    """a is on its dock at 50 %, charging to 90 %: a task beside it goes to b, idle and
    farther, at once (it used to be queued for a "(finishes first)", behind the charge; a
    schedule's dispatch and a re-offer after a failure bid the same way)."""
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 14.0, Y), speed=4.0)
    try:
        await battery(w, "a", 20.0)
        await w.until(lambda: robots(w)["a"]["state"] == "charging", 40, "a on its dock")
        await battery(w, "a", 50.0)  # above the threshold; its charge goes on to 90 %
        charge = next(t for t in tasks(w) if t["kind"] == "charge" and t["robot"] == "a")
        assert state(w, charge["id"]) == "running"
        got = await dispatch(w, target=pose(5.0, Y))
        assert got["accepted"] and got["robot"] == "b", got
        assert "charges first" in got["message"], got
        await w.until(lambda: state(w, got["task"]) == "succeeded", 40, "b arriving")
    finally:
        await w.close()


async def test_a_task_a_cmd_vel_took_over_names_who(make_server, tmp_path):
    """b's task ended by someone driving b by hand: the task says who took b over (it used to
    say only "superseded by a new action")."""
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 14.0, Y), speed=1.0)
    try:
        got = await dispatch(w, target=pose(8.0, Y), robot="b")
        assert got["robot"] == "b", got
        await w.until(lambda: state(w, got["task"]) == "running", 10, "b on its way")
        await w.until(lambda: robots(w)["b"]["state"] != "idle", 10, "b moving")
        await w.publish("/b/cmd_vel", {"linear": {"x": 0.2, "y": 0.0, "z": 0.0},
                                       "angular": {"x": 0.0, "y": 0.0, "z": 0.0}},
                        "geometry_msgs/Twist")
        await w.until(lambda: "taken over by a /cmd_vel from" in
                      (task(w, got["task"]) or {}).get("message", ""), 15, "who took b over")
    finally:
        await w.close()


async def test_bids_say_why_and_a_battery_that_would_not_last_charges_first(make_server,
                                                                            tmp_path):
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 12.0, Y))
    try:
        await add_poi(w, "west", 3.0, Y)
        await add_poi(w, "east", 13.0, Y)
        await battery(w, "a", 30.0)  # above the threshold, below a long patrol's need
        got = await w.call("/fleet/dispatch", {"kind": "patrol", "pois": ["west", "east"],
                                               "laps": 40, "poi": "", "pose": pose(0, 0),
                                               "robot": ""}, timeout=15)
        reply = got["values"]
        assert reply["accepted"] and reply["robot"] == "b", reply
        assert "a " in reply["message"] and "charges first" in reply["message"], reply
        patrol = task(w, reply["task"])
        assert patrol["kind"] == "patrol" and patrol["laps"] == 40
        assert patrol["pois"] == ["west", "east"]
        assert (await w.call("/fleet/cancel", {"task": reply["task"]}))["values"]["success"]
        named = await dispatch(w, target=pose(10.0, Y), robot="a")  # far from a: still a
        assert named["robot"] == "a", named
        await w.until(lambda: state(w, named["task"]) == "succeeded", 40, "a arriving")
    finally:
        await w.close()


async def test_pause_resume_out_of_service_and_history(make_server, tmp_path):
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 20.0, Y), speed=1.0)
    try:
        await add_poi(w, "p1", 8.0, Y)
        await add_poi(w, "p2", 9.0, Y)
        seq = (await w.call("/fleet/dispatch", {
            "kind": "sequence", "pois": ["p1", "p2"], "dwell": [0.2, 0.0], "robot": "a",
            "poi": "", "pose": pose(0, 0)}, timeout=15))["values"]
        assert seq["robot"] == "a", seq
        paused = await w.call("/fleet/pause", {"task": seq["task"]})
        assert paused["values"]["success"], paused
        await w.until(lambda: state(w, seq["task"]) == "paused"
                      and robots(w)["a"]["state"] == "idle", 10, "a stopped")
        again = await w.call("/fleet/pause", {"task": seq["task"]})
        assert not again["values"]["success"] and "paused" in again["values"]["message"]
        # a out of service: a task it would win goes to b instead
        off = await w.call("/fleet/set_in_service", {"robot": "a", "in_service": False})
        assert off["values"]["success"], off
        await w.until(lambda: robots(w)["a"]["in_service"] is False, 3, "a listed out")
        near_a = await dispatch(w, target=pose(5.0, Y))
        assert near_a["robot"] == "b" and "a " not in near_a["message"], near_a
        assert (await w.call("/fleet/resume", {"task": seq["task"]}))["values"]["success"]
        assert state(w, seq["task"]) == "queued"  # named for a, which is out of service
        await w.call("/fleet/set_in_service", {"robot": "a", "in_service": True})
        await w.until(lambda: state(w, seq["task"]) == "succeeded", 40, "a finishing")
        await w.until(lambda: at(w, "a", 9.0, Y), 3, "a listed at p2, the sequence's end")
        history = (await w.call("/fleet/history", {"robot": "a", "limit": 5}))["values"]
        assert [t["id"] for t in history["tasks"]][:1] == [seq["task"]]
        first = history["tasks"][0]
        assert first["kind"] == "sequence" and first["dwell"] == [0.2, 0.0]
        assert first["state"] == "succeeded" and first["started"] >= first["created"] > 0
        await w.until(lambda: state(w, near_a["task"]) == "succeeded", 60, "b arriving")
        both = (await w.call("/fleet/history", {"robot": "", "limit": 0}))["values"]["tasks"]
        assert [t["id"] for t in both] == sorted((t["id"] for t in both), reverse=True)
        assert {t["assigned"] for t in both} == {"a", "b"}
    finally:
        await w.close()


async def test_the_queue_is_bounded_and_targets_are_checked(make_server, tmp_path):
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 12.0, Y))
    try:
        for target, needle in ((pose(1e308, Y), "off the map"),
                               (pose(float("inf"), Y), "pose.position"),
                               (pose(200.0, 200.0), "off the map"),
                               (pose(10.0, 0.1), "(10, 0.1) is on an obstacle")):
            got = await dispatch(w, target=target)
            assert not got["accepted"] and needle in got["message"], (target, got)
        await w.call("/fleet/set_in_service", {"robot": "b", "in_service": False})
        accepted = [await dispatch(w, target=pose(10.0 + i % 5, Y), robot="b")
                    for i in range(50)]
        assert all(g["accepted"] and g["robot"] == "" for g in accepted)
        full = await dispatch(w, target=pose(11.0, Y), robot="b")
        assert not full["accepted"] and "already has 50 tasks waiting" in full["message"]
        assert sum(t["state"] == "queued" for t in tasks(w)) == 50
        bad = await w.call("/fleet/dispatch", {"kind": "teleport", "poi": "", "robot": "",
                                               "pose": pose(5, Y)})
        assert not bad["values"]["accepted"] and "kind" in bad["values"]["message"]
    finally:
        await w.close()


class HeldClock:
    """The fleet's wall clock, held by the test and moved on by hand."""

    def __init__(self, now: float):
        self.now = now

    def __call__(self) -> float:
        return self.now


async def clocked(tmp_path, state_dir, clock: HeldClock) -> HitrobotServer:
    settings = Settings.of(
        port=0, tcp_port=-1, address="127.0.0.1", unregister_timeout=0.2, robot="none",
        state_dir=str(state_dir), map_dir=str(tmp_path / "maps"), sim_speed=4.0,
        site_timezone="UTC", robots=(RobotEntry("a", "sim", (4.0, Y, 0.0)),
                                     RobotEntry("b", "sim", (12.0, Y, 0.0))))
    server = HitrobotServer(dataclasses.replace(
        settings, nodes=dataclasses.replace(settings.nodes, fleet_clock=clock)))
    await server.start()
    return server


async def open_watcher(server: HitrobotServer) -> Watcher:
    w = await Watcher.open(server.port)
    for topic in ("/fleet/robots", "/fleet/tasks", "/map_manager/pois"):
        await w.subscribe(topic)
    await w.until(lambda: len([r for r in robots(w).values() if r["state"] == "idle"]) == 2,
                  15, "both robots idle")
    return w


async def test_schedules_fire_on_the_held_clock_and_everything_survives_a_restart(tmp_path):
    day = 1_800_000_000.0  # 2027-01-15 08:00 UTC
    clock = HeldClock(day)
    state_dir = tmp_path / "state"
    server = await clocked(tmp_path, state_dir, clock)
    w = await open_watcher(server)
    try:
        await add_poi(w, "desk", 6.0, Y)
        added = (await w.call("/fleet/schedule_add", {
            "when": "every 2 h", "poi": "desk", "pose": pose(0, 0), "robot": "", "kind": ""}
        ))["values"]
        assert added["success"], added
        daily = (await w.call("/fleet/schedule_add", {"when": "daily 09:00", "poi": "desk"}))
        assert daily["values"]["success"], daily
        for when, needle in (("every 1 s", "at least 10 s"), ("hourly", "neither"),
                             ("daily 25:00", "not a time of day")):
            bad = await w.call("/fleet/schedule_add", {"when": when, "poi": "desk"})
            assert not bad["values"]["success"] and needle in bad["values"]["message"], when
        listed = (await w.call("/fleet/schedule_list"))["values"]["schedules"]
        assert [(s["when"], s["next"]) for s in listed] == [("every 2 h", day + 7200),
                                                          ("daily 09:00", day + 3600)]
        removed = await w.call("/fleet/schedule_remove", {"task": daily["values"]["id"]})
        assert removed["values"]["success"]
        clock.now = day + 7200  # the slot is due: the next check fires it
        await w.until(lambda: any(t["poi"] == "desk" for t in tasks(w)), 5, "the slot firing")
        fired = next(t for t in tasks(w) if t["poi"] == "desk")
        await w.until(lambda: state(w, fired["id"]) == "succeeded", 30, "the task done")
        listed = (await w.call("/fleet/schedule_list"))["values"]["schedules"]
        assert listed[0]["last"] == day + 7200 and listed[0]["next"] == day + 14400
        paused = await dispatch(w, target=pose(10.0, Y), robot="b")
        await w.call("/fleet/pause", {"task": paused["task"]})
    finally:
        await w.close()
        await server.stop()
    clock.now = day + 7200 + 5 * 3600  # two slots (4 h, 6 h) pass while the server is down
    server = await clocked(tmp_path, state_dir, clock)
    w = await open_watcher(server)
    try:
        history = (await w.call("/fleet/history", {"robot": "", "limit": 10}))["values"]
        assert fired["id"] in [t["id"] for t in history["tasks"]]
        await w.until(lambda: state(w, paused["task"]) == "paused", 5, "the paused task back")
        schedule = (await w.call("/fleet/schedule_list"))["values"]["schedules"][0]
        assert "missed 2 slot(s)" in schedule["message"] or "missed 2" in str(
            schedule), schedule
        await w.until(lambda: sum(t["poi"] == "desk" and t["id"] > fired["id"]
                                  for t in tasks(w)) == 1, 5, "the missed slots run once")
        assert schedule["next"] == day + 7200 + 6 * 3600
    finally:
        await w.close()
        await server.stop()


async def test_a_task_paused_and_resumed_at_once_resumes(make_server, tmp_path):
    """Issue 52, item 4: the pause and the resume written back to back, before either answer
    is read (the stopped motion used to fail the task: "its motion was stopped")."""
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 20.0, Y), speed=2.0)
    try:
        sent = await dispatch(w, target=pose(10.0, Y), robot="a")
        assert sent["robot"] == "a", sent
        await w.until(lambda: robots(w)["a"]["state"] == "moving", 10, "a on its way")
        for i, service in enumerate(("/fleet/pause", "/fleet/resume")):
            await w.client.send({"op": "call_service", "id": f"pr{i}", "service": service,
                                 "args": {"task": sent["task"]}})
        await w.until(lambda: {"pr0", "pr1"} <= set(w.replies), 10, "both answers")
        assert all(w.replies[i]["values"]["success"] for i in ("pr0", "pr1")), w.replies
        await w.until(lambda: state(w, sent["task"]) in ("succeeded", "failed"), 40,
                      "the task ending")
        assert state(w, sent["task"]) == "succeeded", task(w, sent["task"])
        await w.until(lambda: at(w, "a", 10.0, Y), 3, "a listed at its target")
    finally:
        await w.close()

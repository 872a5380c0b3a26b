"""The charging rule wherever a task is offered (issue 46, friction 2), each path against the
real server with simulated robots: a robot below the charge threshold, on its dock, never leaves
it for a task (nor keeps one waiting behind its charge) while a charged robot stands idle. A
first dispatch is tested in test_fleet_ops.py
(``test_a_low_robot_charges_on_its_own_and_new_work_goes_to_the_other``); here a re-offer after
a failure, a schedule's dispatch, a resumed task and a robot back in service."""

from __future__ import annotations

from tests.helpers import Watcher
from tests.nodes.fleet.test_node import Y, add_poi, dispatch, fleet, pose, robots, task
from tests.nodes.fleet.test_operations import (
    HeldClock,
    battery,
    clocked,
    open_watcher,
    state,
    tasks,
)


async def low_on_its_dock(w: Watcher, name: str) -> int:
    """``name`` at 20 %: the fleet sends it to charge; it is on its dock. Its charge task."""
    await battery(w, name, 20.0)
    await w.until(lambda: robots(w)[name]["state"] == "charging", 40, f"{name} on its dock")
    return next(t["id"] for t in tasks(w) if t["kind"] == "charge" and t["robot"] == name
                and t["state"] == "running")


def said(w: Watcher, task_id: int, words: str) -> bool:
    """Some /fleet/tasks message showed task ``task_id`` with ``words`` in its message."""
    return any(words in t["message"] for _t, m in w.messages.get("/fleet/tasks", [])
               for t in m["tasks"] if t["id"] == task_id)


async def done_by(w: Watcher, task_id: int, robot: str, low: str, charge: int) -> None:
    """The task runs to its end on ``robot`` while ``low`` stays on its dock, charging."""
    def check() -> bool:
        assert robots(w)[low]["state"] == "charging", robots(w)[low]  # never left its dock
        assert state(w, charge) == "running"
        return state(w, task_id) == "succeeded"
    await w.until(check, 40, f"{robot} finishing task {task_id}")
    assert task(w, task_id)["assigned"] == robot, task(w, task_id)


async def test_a_resumed_task_goes_to_the_idle_robot_not_behind_a_charge(make_server, tmp_path):
    """a wins a task (queued for it behind its other work), which is paused; a goes low and
    docks; resumed, the task is offered again and b takes it (it used to stay queued for a,
    behind a charge to 90 %, while b stood idle)."""
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 16.0, Y), speed=3.0)
    try:
        first = await dispatch(w, target=pose(7.0, Y), robot="a")
        later = await dispatch(w, target=pose(5.0, Y))  # a finishes first, after `first`
        assert later["robot"] == "" and "queued for a" in later["message"], later
        assert (await w.call("/fleet/pause", {"task": later["task"]}))["values"]["success"]
        await w.until(lambda: state(w, first["task"]) == "succeeded", 40, "a's first task")
        charge = await low_on_its_dock(w, "a")
        resumed = await w.call("/fleet/resume", {"task": later["task"]})
        assert resumed["values"]["success"], resumed
        await done_by(w, later["task"], "b", "a", charge)
        assert said(w, later["task"], "resumed; queued for b — bids: b ")
    finally:
        await w.close()


async def test_a_robot_back_in_service_takes_what_waited_behind_a_charge(make_server,
                                                                        tmp_path):
    """b out of service, a low on its dock: a task can only be queued for a (it charges
    first). b back in service: the task is offered again and b runs it at once."""
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 16.0, Y), speed=3.0)
    try:
        off = await w.call("/fleet/set_in_service", {"robot": "b", "in_service": False})
        assert off["values"]["success"], off
        charge = await low_on_its_dock(w, "a")
        waiting = await dispatch(w, target=pose(6.0, Y))
        assert waiting["accepted"] and waiting["robot"] == "", waiting
        assert "queued for a" in waiting["message"] and "charges first" in waiting["message"]
        back = await w.call("/fleet/set_in_service", {"robot": "b", "in_service": True})
        assert back["values"]["success"], back
        await done_by(w, waiting["task"], "b", "a", charge)
        assert said(w, waiting["task"], "b is back in service; queued for b — bids: b ")
    finally:
        await w.close()


async def test_a_failed_task_is_offered_past_a_low_robot(make_server, tmp_path):
    """a low on its dock beside the target, b runs the task and fails: offered again, c
    (charged, idle, farther) takes it, not a."""
    _server, w = await fleet(make_server, tmp_path, ("a", 4.0, Y), ("b", 9.0, Y),
                             ("c", 18.0, Y), speed=1.0)
    try:
        charge = await low_on_its_dock(w, "a")
        got = await dispatch(w, target=pose(6.0, Y))
        assert got["robot"] == "b", got
        await w.until(lambda: robots(w)["b"]["state"] == "moving", 10, "b moving")
        sat = await w.call("/b/sit_down")
        assert sat["values"]["success"], sat
        await w.until(lambda: "b" in (task(w, got["task"]) or {}).get("tried", []), 15,
                      "the failure reported")
        await done_by(w, got["task"], "c", "a", charge)
    finally:
        await w.close()


async def test_a_schedule_sends_the_idle_robot_not_the_low_one(tmp_path):
    """A slot fires for a POI beside a, low on its dock: b goes."""
    day = 1_800_000_000.0
    clock = HeldClock(day)
    server = await clocked(tmp_path, tmp_path / "state", clock)
    w = await open_watcher(server)
    try:
        await add_poi(w, "desk", 6.0, Y)
        added = (await w.call("/fleet/schedule_add", {"when": "every 2 h", "poi": "desk"}))
        assert added["values"]["success"], added
        charge = await low_on_its_dock(w, "a")
        clock.now = day + 7200
        await w.until(lambda: any(t["poi"] == "desk" for t in tasks(w)), 5, "the slot firing")
        fired = next(t for t in tasks(w) if t["poi"] == "desk")
        await done_by(w, fired["id"], "b", "a", charge)
    finally:
        await w.close()
        await server.stop()

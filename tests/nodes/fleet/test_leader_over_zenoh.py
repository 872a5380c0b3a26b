"""One fleet queue per site across two real servers joined over Zenoh, one robot each: the
first server up dispatches (a live dispatcher is kept), the other forwards ``/fleet/*`` to it
and both servers' clients see the same ``/fleet/tasks``; kill -9 of the dispatcher's server
with tasks queued: the other takes over, every acknowledged task is still there and runs once,
and the task whose robot went down with the dispatcher fails with that reason."""

from __future__ import annotations

import time
from collections import Counter

from tests.bus.test_zenoh_scale_out import free_port, zenoh_server
from tests.helpers import Watcher
from tests.nodes.fleet.test_fleet_over_zenoh import Y, close_all, names, pose

TASKS = "/fleet/tasks"


def tasks(w: Watcher) -> dict[int, dict]:
    return {t["id"]: t for t in (w.latest(TASKS) or {"tasks": []})["tasks"]}


def lists(w: Watcher, since: int) -> list[list[dict]]:
    return [m["tasks"] for _t, m in w.messages.get(TASKS, [])[since:]]


async def dispatch(w: Watcher, x: float, robot: str) -> int:
    reply = (await w.call("/fleet/dispatch", {"poi": "", "pose": pose(x, Y), "robot": robot},
                          timeout=20))["values"]
    assert reply["accepted"] and "copied to" not in reply["message"], reply
    return reply["task"]


async def test_one_queue_across_servers_and_take_over_after_kill_9(tmp_path):
    port = free_port()
    one_args = ("--map-dir", str(tmp_path / "one"), "--state-dir", str(tmp_path / "s1"),
                "--sim-speed", "1.5")
    one = zenoh_server(listen=port, robot="a=sim@4,8", extra=one_args)
    two = w1 = w2 = None
    try:
        w1 = await Watcher.open(one.port)
        for topic in ("/fleet/robots", TASKS):
            await w1.subscribe(topic)
        await w1.until(lambda: names(w1) == {"a"}, 30, "server one dispatching alone")
        two = zenoh_server(connect=port, robot="b=sim@12,8",
                           extra=("--map-dir", str(tmp_path / "two"), "--sim-speed", "1.5"))
        w2 = await Watcher.open(two.port)
        for topic in ("/fleet/robots", TASKS):
            await w2.subscribe(topic)
        await w1.until(lambda: names(w1) == {"a", "b"}, 30, "both robots on server one")
        await w2.until(lambda: names(w2) == {"a", "b"}, 30, "both robots on server two")
        await w2.until(lambda: w2.latest(TASKS) is not None, 10, "the dispatcher's tasks")
        marks = len(w1.messages[TASKS]), len(w2.messages[TASKS])

        # sent to the follower, queued by the dispatcher, run on the follower's own robot
        first = await dispatch(w2, 13.0, "")
        await w2.until(lambda: tasks(w2).get(first, {}).get("state") == "succeeded", 40,
                       "b arriving, seen from server two")
        assert tasks(w2)[first]["assigned"] == "b"
        await w1.until(lambda: w1.latest(TASKS) == w2.latest(TASKS), 10, "the same list")
        # one publisher: every change reached both servers' clients, the same and in order
        assert lists(w1, marks[0]) == lists(w2, marks[1])
        assert len(lists(w2, marks[1])) >= 2

        # the queue at the kill: b runs one task and has two waiting, a runs one
        on_b = [await dispatch(w2, x, "b") for x in (16.0, 14.0, 12.0)]
        on_a = await dispatch(w2, 9.0, "a")
        assert [tasks(w2)[i]["state"] for i in on_b[1:]] == ["queued", "queued"]
        await w2.until(lambda: tasks(w2).get(on_a, {}).get("state") == "running", 10,
                       "a on its way")
        one.kill()
        killed = time.monotonic()
        seen = len(w2.messages[TASKS])
        await w2.until(lambda: len(w2.messages[TASKS]) > seen, 10, "server two taking over")
        took = time.monotonic() - killed
        await w2.until(lambda: tasks(w2).get(on_a, {}).get("state") == "failed", 15,
                       "a's task failed with its robot")
        settled = time.monotonic() - killed
        assert "went down with the dispatcher" in tasks(w2)[on_a]["message"]
        await w2.until(lambda: all(tasks(w2).get(i, {}).get("state") == "succeeded"
                                   for i in on_b), 60, "b's three tasks done")
        history = (await w2.call("/fleet/history", {"robot": "", "limit": 0}))["values"]
        counts = Counter(t["id"] for t in history["tasks"])
        assert all(counts[i] == 1 for i in [first, on_a, *on_b]), counts
        assert max(counts.values()) == 1, counts
        # a new dispatch on the new dispatcher: ids go on from the copied board
        last = await dispatch(w2, 13.0, "b")
        assert last > max(on_b)

        # server one back with its folder (a's task running, b's two queued: a stale queue):
        # it follows the dispatcher, its clients see the dispatcher's list, nothing runs again
        one.stop()
        await w1.close()
        one = zenoh_server(listen=port, robot="a=sim@4,8", extra=one_args)
        w1 = await Watcher.open(one.port)
        for topic in ("/fleet/robots", TASKS):
            await w1.subscribe(topic)
        await w1.until(lambda: tasks(w1).get(on_a, {}).get("state") == "failed", 20,
                       "server one following server two")
        await w1.until(lambda: names(w1) == {"a", "b"}, 30, "a back, on the dispatcher's list")
        again = await dispatch(w1, 6.0, "a")  # through server one, to server two's queue
        assert again == last + 1
        await w1.until(lambda: tasks(w1).get(again, {}).get("state") == "succeeded", 40,
                       "a's new task done, seen from server one")
        history = (await w1.call("/fleet/history", {"robot": "", "limit": 0}))["values"]
        counts = Counter(t["id"] for t in history["tasks"])
        assert max(counts.values()) == 1 and counts[again] == 1, counts
        print(f"take-over: the new dispatcher's first /fleet/tasks {took:.2f} s after kill -9, "
              f"the dead robot's task failed after {settled:.2f} s")
    finally:
        await close_all((w1, w2), (two, one))

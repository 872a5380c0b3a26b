"""The fleet of a real ``hitrobot-server`` process with two simulated robots: its history and
open tasks survive kill -9, and dispatches to places no robot can reach are refused at once
and leave the server idle (they used to stay queued, replanned at 100 % CPU)."""

from __future__ import annotations

import asyncio
import os
import time
from pathlib import Path

import pytest

from tests.helpers import ServerProcess, Watcher
from tests.nodes.fleet.test_node import Y, pose
from tests.witness import RoundTrips

ROBOTS = ("--robot", "b=sim@12,8", "--sim-speed", "4")
FIRST = "a=sim@4,8"  # ServerProcess's own --robot
ATTACK = 300
"""Dispatches to one unreachable place, the issue's burst (the robots' planners refuse a target
outside the start's region without a search)."""


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


async def fleet_watcher(port: int) -> Watcher:
    w = await Watcher.open(port)
    for topic in ("/fleet/robots", "/fleet/tasks"):
        await w.subscribe(topic)

    def idle() -> bool:
        latest = w.latest("/fleet/robots")
        return bool(latest) and sum(r["state"] == "idle" for r in latest["robots"]) == 2

    await w.until(idle, 30, "both robots idle")
    return w


def task_state(w: Watcher, task_id: int) -> str:
    latest = w.latest("/fleet/tasks") or {"tasks": []}
    return next((t["state"] for t in latest["tasks"] if t["id"] == task_id), "")


async def test_history_and_open_tasks_survive_kill_9(tmp_path):
    args = (*ROBOTS, "--state-dir", str(tmp_path / "state"), "--map-dir", str(tmp_path / "m"))
    server = ServerProcess(*args, robot=FIRST)
    try:
        w = await fleet_watcher(server.port)
        done = (await w.call("/fleet/dispatch", {"poi": "", "pose": pose(6.0, Y), "robot": ""},
                             timeout=20))["values"]
        assert done["robot"] == "a", done
        await w.until(lambda: task_state(w, done["task"]) == "succeeded", 30, "a arriving")
        held = (await w.call("/fleet/dispatch", {"poi": "", "pose": pose(16.0, Y),
                                                 "robot": "b"}, timeout=20))["values"]
        assert (await w.call("/fleet/pause", {"task": held["task"]}))["values"]["success"]
        # the pause's reply came after its change was put; the history's line before it
        await w.call("/fleet/history", {"robot": "", "limit": 1})
        await w.close()
        server.kill()
    finally:
        server.stop()
    server = ServerProcess(*args, robot=FIRST)
    try:
        w = await fleet_watcher(server.port)
        history = (await w.call("/fleet/history", {"robot": "a", "limit": 10}))["values"]
        assert [t["id"] for t in history["tasks"]] == [done["task"]], history
        assert history["tasks"][0]["state"] == "succeeded"
        await w.until(lambda: task_state(w, held["task"]) == "paused", 5, "the paused task")
        await w.close()
    finally:
        server.stop()


@pytest.mark.serial  # the server's CPU share and the witness's bound: run alone (tests/run.py)
async def test_unreachable_dispatches_are_refused_and_cost_nothing_after(tmp_path):
    # at the simulator's own speed: the robots stand still, the witness measures the dispatches
    server = ServerProcess("--robot", "b=sim@12,8", "--map-dir", str(tmp_path / "m"), robot=FIRST)
    try:
        w = await fleet_watcher(server.port)
        # the first plan builds each robot's costmap and labels its regions (once per map)
        first = await w.call("/fleet/dispatch", {"poi": "", "pose": pose(10.0, 0.1),
                                                 "robot": ""}, timeout=60)
        assert not first["values"]["accepted"], first
        witness = await RoundTrips.open(server.port)
        replies = await asyncio.gather(*(w.call("/fleet/dispatch", {
            "poi": "", "pose": pose(10.0, 0.1 - (i % 3) * 0.01), "robot": ""}, timeout=120)
            for i in range(ATTACK)))  # on the map, in the outer wall: no path from anywhere
        worst_during = await witness.stop()
        # refused by the placement rule before any plan (issue 46; they used to be planned,
        # the planners' regions refusing them without a search)
        assert all(not r["values"]["accepted"] and "obstacle" in r["values"]["message"]
                   for r in replies), replies[0]
        latest = w.latest("/fleet/tasks") or {"tasks": []}
        assert not [t for t in latest["tasks"] if t["state"] == "queued"]
        # the planners' regions refuse them without a search: the loop stays free
        assert worst_during <= 0.5, witness.times
        # afterwards the server runs the robots' simulation only: its CPU stays well under a
        # core (it was 100 % with nobody asking), the witness is answered at once
        before, began = cpu_seconds(server.proc.pid), time.monotonic()
        witness = await RoundTrips.open(server.port)
        await asyncio.sleep(2.0)  # the span measured (no synchronisation waits on it)
        worst_after = await witness.stop()
        share = (cpu_seconds(server.proc.pid) - before) / (time.monotonic() - began)
        assert share < 0.6, f"{share:.0%} of a core after the attack"
        assert worst_after < 0.5, worst_after
        await w.close()
    finally:
        server.stop()

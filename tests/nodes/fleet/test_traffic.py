"""The traffic rule on its own (no robots): a path cut into runs of zones, all of a run's zones
granted at once or none, first come first served, a robot standing in a zone first, a zone let
go only once its holder is past it and clear of it, a withdrawn wait."""

from __future__ import annotations

import asyncio

import numpy as np

from hitrobot_server.nodes.fleet.board import Board
from hitrobot_server.nodes.fleet.member import OFFLINE
from hitrobot_server.nodes.fleet.policy import ChargePolicy
from hitrobot_server.nodes.fleet.roster import Roster
from hitrobot_server.nodes.fleet.traffic import NEAR, Traffic
from hitrobot_server.nodes.fleet.zones import Zone
from tests.nodes.fleet.test_node import pose

A = Zone("a", "door", ((2.0, -1.0), (3.0, -1.0), (3.0, 1.0), (2.0, 1.0)))
B = Zone("b", "door", ((3.2, -1.0), (4.0, -1.0), (4.0, 1.0), (3.2, 1.0)))  # touches a's band
C = Zone("c", "corridor", ((8.0, -1.0), (10.0, -1.0), (10.0, 1.0), (8.0, 1.0)))


def traffic(poses: dict[str, tuple[float, float]]) -> Traffic:
    t = Traffic(poses.get, lambda: None)
    for zone in (A, B, C):
        t.put(zone)
    return t


def line(x0: float, x1: float) -> np.ndarray:
    xs = np.arange(x0, x1 + 1e-9, 0.05)
    return np.stack([xs, np.zeros_like(xs)], axis=1)


def test_a_path_is_cut_into_runs_with_clear_ends():
    path = line(0.0, 12.0)
    runs = traffic({}).runs(path)
    assert [sorted(r.zones) for r in runs] == [["a", "b"], ["c"]]  # a and b: no clear gap
    for run in runs:
        x_in, x_out = path[run.entry][0], path[run.exit][0]
        for zone in (A, B, C):
            assert zone.distance(path[[run.entry, run.exit]]).min() >= NEAR - 1e-9
        assert x_in < x_out
    assert abs(path[runs[0].entry][0] - (2.0 - NEAR)) < 0.06
    assert abs(path[runs[1].exit][0] - (10.0 + NEAR)) < 0.06


async def test_all_or_nothing_first_come_first_served_and_release_once_clear():
    poses = {"r1": (0.0, 0.0), "r2": (12.0, 0.0), "r3": (6.0, 0.0)}
    t = traffic(poses)
    said: list[str] = []
    assert await t.acquire("r1", frozenset({"a", "b"}), said.append)
    second = asyncio.ensure_future(t.acquire("r2", frozenset({"b"}), said.append))
    third = asyncio.ensure_future(t.acquire("r3", frozenset({"b", "c"}), said.append))
    await asyncio.sleep(0)
    assert not second.done() and not third.done()
    assert said == ["waiting for zone b (held by r1)", "waiting for zone b, c (held by r1)"]
    assert t.msg()["zones"][1]["waiting"] == ["r2", "r3"]
    poses["r1"] = (3.1, 0.0)  # between a and b
    t.moved("r1")  # not past them yet: held
    assert t.holders["b"] == {"r1": False}
    t.passed("r1", frozenset({"a", "b"}))  # past them on its path, but not clear of b yet
    assert t.holders["b"] == {"r1": True} and not second.done()
    poses["r1"] = (5.0, 0.0)  # out
    t.moved("r1")
    await asyncio.sleep(0)
    assert second.result() is True and not third.done()  # r3 wants b too: r2 asked first
    assert t.holders["c"] == {}  # c stays free for r3: no later request overtakes it
    t.withdraw("r3")
    await asyncio.sleep(0)
    assert third.result() is False and t.queue == []


async def test_a_robot_standing_in_a_zone_holds_it_and_goes_first():
    poses = {"in": (9.0, 0.0), "out": (6.0, 0.0)}
    t = traffic(poses)
    t.moved("in")
    assert t.holders["c"] == {"in": True}
    waiting = asyncio.ensure_future(t.acquire("out", frozenset({"c"}), lambda _text: None))
    await asyncio.sleep(0)
    assert await t.acquire("in", frozenset({"c", "b"}), lambda _text: None)  # no queueing
    assert not waiting.done()
    poses["in"] = (12.0, 0.0)
    t.passed("in")
    await asyncio.sleep(0)
    assert waiting.result() is True and set(t.holders["c"]) == {"out"}
    assert t.holders["b"] == {}


async def test_a_zone_drawn_over_two_robots_says_so_lets_them_out_and_no_other_in():
    poses = {"r1": (2.5, 0.0), "r2": (2.5, 0.5), "r3": (0.0, 0.0)}
    t = traffic(poses)
    t.moved("r1")
    t.moved("r2")
    assert set(t.holders["a"]) == {"r1", "r2"}
    assert t.crowded("a") == ("robots r1, r2 stand in zone a, more than its capacity of 1: "
                              "no other robot goes in until they are out")
    said: list[str] = []
    outsider = asyncio.ensure_future(t.acquire("r3", frozenset({"a"}), said.append))
    await asyncio.sleep(0)
    assert not outsider.done() and said == ["waiting for zone a (held by r1, r2)"]
    assert await t.acquire("r1", frozenset({"a", "b"}), said.append)  # it leaves through it
    poses["r1"] = (6.0, 0.0)
    t.passed("r1")
    assert not outsider.done()  # r2 still stands in it
    poses["r2"] = (-1.0, 0.0)
    t.moved("r2")
    assert await asyncio.wait_for(outsider, 1) and t.crowded("a") == ""


def test_an_offline_robot_stays_where_it_was_last_seen():
    roster = Roster(Board(None), ChargePolicy())
    never = {"name": "n", "state": OFFLINE, "battery": 0.0, "pose": pose(0.0, 0.0)}
    roster.heard(never)
    assert roster.pose_of("n") is None  # never seen anywhere: not at the origin
    roster.heard({**never, "name": "r", "state": "idle", "pose": pose(2.5, 0.0)})
    roster.heard({**never, "name": "r"})  # its link lost: the report says (0, 0)
    assert roster.pose_of("r") == (2.5, 0.0)
    t = Traffic(roster.pose_of, lambda: None)
    t.put(A)
    t.moved("r")
    assert t.holders["a"] == {"r": True}  # it still stands in the zone: held

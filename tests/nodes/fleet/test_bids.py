"""Bidding as a pure function (nodes/fleet/policy.py ``bids``): the task, a snapshot of the
robots, their plans of the first leg and the policy give the bids and the refusals; no bus, no
robot, no clock."""

from __future__ import annotations

import math

from hitrobot_server.nodes.fleet.policy import Bidder, ChargePolicy, bids, metres, winner
from hitrobot_server.nodes.fleet.tasks import PATROL, Stop, Task
from hitrobot_server.robot.model import Pose2D

POLICY = ChargePolicy(speed=0.5, drain=0.05, reserve=5.0, charge_until=90.0, charge_rate=0.25)
PATH = object()  # a plan's path: only whether there is one counts


def goto(x: float, y: float, dwell: float = 0.0) -> Task:
    return Task(1, "goto", [Stop("", Pose2D(x, y, 0.0), dwell)], "")


def test_the_nearer_idle_robot_finishes_first_and_a_robot_without_a_plan_says_why():
    task = goto(10.0, 0.0, dwell=4.0)
    robots = [Bidder("a", 80.0, 0.0), Bidder("b", 80.0, 0.0), Bidder("c", 80.0, 0.0)]
    plans = [(2.0, PATH, ""), (6.0, PATH, ""), (math.inf, None, "no path: a wall")]
    offers, refusals = bids(task, robots, plans, POLICY)
    assert [(b.robot, b.finish, b.metres, b.charge) for b in offers] == [
        ("a", 2.0 / 0.5 + 4.0, 2.0, False), ("b", 6.0 / 0.5 + 4.0, 6.0, False)]
    assert refusals == ["c: no path: a wall"]
    assert winner(offers).robot == "a"


def test_work_before_it_and_a_battery_that_would_not_last_add_to_the_finish():
    task = goto(10.0, 0.0)
    robots = [Bidder("busy", 80.0, 30.0), Bidder("low", 10.0, 0.0)]
    plans = [(2.0, PATH, ""), (200.0, PATH, "")]
    busy, low = bids(task, robots, plans, POLICY)[0]
    assert busy.finish == 30.0 + 4.0 and not busy.charge and busy.busy == 30.0
    # 200 m take 10 %; 10 % − 10 % leaves less than the 5 % reserve: it charges first
    assert low.charge and low.finish == 200.0 / 0.5 + (90.0 - 10.0) / 0.25
    assert "charges first" in low.why(POLICY) and "30 s of work before it" in busy.why(POLICY)
    assert winner([low, busy]).robot == "busy"


def test_a_patrol_counts_every_lap_after_the_planned_first_leg():
    stops = [Stop("p", Pose2D(0.0, 0.0, 0.0), 1.0), Stop("q", Pose2D(3.0, 4.0, 0.0), 2.0)]
    task = Task(1, PATROL, stops, "", laps=2)
    (offer,), _ = bids(task, [Bidder("a", 100.0, 0.0)], [(1.0, PATH, "")], POLICY)
    rest = metres(task.route[1:], (0.0, 0.0))  # q, p, q: 5 + 5 + 5
    assert rest == 15.0 and offer.metres == 16.0
    assert offer.finish == 16.0 / 0.5 + 2 * (1.0 + 2.0)


def test_equal_finishes_go_to_the_first_name():
    task = goto(1.0, 0.0)
    offers, _ = bids(task, [Bidder("b", 50.0, 0.0), Bidder("a", 50.0, 0.0)],
                     [(1.0, PATH, ""), (1.0, PATH, "")], POLICY)
    assert winner(offers).robot == "a"


def test_a_robot_below_the_threshold_charges_before_a_task_however_short():
    """alpha at 24 % ("below 25 %: charges once free") beside the task, beta at 77 % farther:
    alpha's bid counts its charge, so beta takes it (a re-offer after a failure and a
    schedule's dispatch bid the same way)."""
    task = goto(5.0, 0.0)
    robots = [Bidder("alpha", 24.0, 0.0), Bidder("beta", 77.0, 0.0)]
    alpha, beta = bids(task, robots, [(1.0, PATH, ""), (10.0, PATH, "")], POLICY)[0]
    assert alpha.charge and alpha.finish == 1.0 / 0.5 + (90.0 - 24.0) / 0.25
    assert not beta.charge and beta.finish == 10.0 / 0.5
    assert winner([alpha, beta]).robot == "beta"
    assert "charges first" in alpha.why(POLICY)


def test_a_charging_robot_bids_with_the_rest_of_its_charge():
    """A robot on its dock at 50 % takes no task before 90 %: its bid waits for that, so an
    idle robot farther away wins instead of the task queuing behind the charge."""
    task = goto(5.0, 0.0)
    robots = [Bidder("alpha", 50.0, 0.0, charging=True), Bidder("beta", 77.0, 0.0)]
    alpha, beta = bids(task, robots, [(1.0, PATH, ""), (10.0, PATH, "")], POLICY)[0]
    assert alpha.charge and alpha.finish == 1.0 / 0.5 + (90.0 - 50.0) / 0.25
    assert winner([alpha, beta]).robot == "beta"
    # at charge_until the charge is done: nothing more to wait for
    (done,), _ = bids(task, [Bidder("alpha", 90.0, 0.0, charging=True)], [(1.0, PATH, "")],
                      POLICY)
    assert done.finish == 1.0 / 0.5 and not done.charge

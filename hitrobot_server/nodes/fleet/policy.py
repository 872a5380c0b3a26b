"""The charging policy and the bids: what a task costs a robot in time and battery.

A robot's bid is its estimated finish time for the task: the time left on what it already has
(its running and reserved tasks, at :attr:`ChargePolicy.speed`), the task's path (the first leg
as the robot plans it, the others as straight lines), the dwell times, and the charge it needs
first when its battery would not last the task (path length × :attr:`ChargePolicy.drain`, with
:attr:`ChargePolicy.reserve` kept to reach the dock).

:func:`bids` is the whole rule, a pure function of the task, a snapshot of the bidding robots
(:class:`Bidder`), their plans of the first leg and the policy: no bus, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from .tasks import Stop, Task

Plan = tuple[float, object | None, str]
"""A robot's plan of a task's first leg: its length, the path (None: none) and why not."""


@dataclass(frozen=True)
class ChargePolicy:
    charge_below: float = 25.0  # % : a free robot below it goes to charge
    charge_until: float = 90.0  # % : a charging robot takes no task until it is back here
    drain: float = 0.05  # % of battery per metre driven (the simulator's at full speed)
    reserve: float = 5.0  # % a robot keeps to reach its dock after a task
    speed: float = 0.5  # m/s, the average speed assumed for time estimates
    charge_rate: float = 0.25  # % per second on the dock (the simulator's)

    def needed(self, metres: float) -> float:
        """Battery (%) a path of ``metres`` takes."""
        return metres * self.drain

    def lasts(self, battery: float, metres: float) -> bool:
        return battery - self.needed(metres) >= self.reserve

    def charges_first(self, robot: Bidder, metres: float) -> bool:
        """The charging rule of every bid (a first dispatch, a schedule's, a re-offer after a
        failure): a robot charges before a task of ``metres`` if it is charging now (until
        :attr:`charge_until`), is below :attr:`charge_below` (it charges once free), or would
        not last the task with its reserve. Its finish counts the charge, so a robot that can
        go now wins over one that must charge first."""
        return (robot.charging and robot.battery < self.charge_until
                or robot.battery < self.charge_below
                or not self.lasts(robot.battery, metres))

    def charge_time(self, battery: float) -> float:
        """Seconds on the dock from ``battery`` to :attr:`charge_until`."""
        return max(0.0, self.charge_until - battery) / self.charge_rate


@dataclass(frozen=True)
class Bid:
    robot: str
    finish: float  # seconds from now
    metres: float  # the task's path
    battery: float  # now
    charge: bool  # it charges first
    busy: float  # seconds of work it has before this task

    def why(self, policy: ChargePolicy) -> str:
        text = (f"{self.robot} {self.finish:.0f} s (path {self.metres:.1f} m, battery "
                f"{self.battery:.0f} % − {policy.needed(self.metres):.1f} %")
        if self.charge:
            text += ", charges first"
        if self.busy:
            text += f", {self.busy:.0f} s of work before it"
        return text + ")"


@dataclass(frozen=True)
class Bidder:
    """A robot as the bids see it: its name, its battery (%), the seconds of work it has
    before this task (its running and reserved tasks) and whether it is charging (a charge
    not finished: it takes no task before :attr:`ChargePolicy.charge_until`)."""

    name: str
    battery: float
    busy: float
    charging: bool = False


def bids(task: Task, robots: Sequence[Bidder], plans: Sequence[Plan],
         policy: ChargePolicy) -> tuple[list[Bid], list[str]]:
    """Each robot's bid for ``task`` (those with a plan of the first leg, ``plans`` in the order
    of ``robots``) and why the others cannot take it."""
    out, refusals = [], []
    first = task.stops[0].pose
    rest = metres(task.route[1:], (first.x, first.y))
    dwell = sum(s.dwell for s in task.route)
    for robot, (length, path, reason) in zip(robots, plans, strict=True):
        if path is None:
            refusals.append(f"{robot.name}: {reason}")
            continue
        total = length + rest
        charge = policy.charges_first(robot, total)
        finish = robot.busy + total / policy.speed + dwell
        if charge:
            finish += policy.charge_time(robot.battery)
        out.append(Bid(robot.name, finish, total, robot.battery, charge, robot.busy))
    return out, refusals


def winner(offers: Sequence[Bid]) -> Bid:
    """The bid that finishes first (ties: the robot's name)."""
    return min(offers, key=lambda b: (b.finish, b.robot))


def metres(stops: Sequence[Stop], start: tuple[float, float]) -> float:
    """The straight-line length from ``start`` through ``stops``."""
    points = [start, *((s.pose.x, s.pose.y) for s in stops)]
    return sum(math.dist(a, b) for a, b in zip(points, points[1:], strict=False))

"""The charging policy and the bids: what a task costs a robot in time and battery.

A robot's bid is its estimated finish time for the task: the time left on what it already has
(its running and reserved tasks, at :attr:`ChargePolicy.speed`), the task's path (the first leg
as the robot plans it, the others as straight lines), the dwell times, and the charge it needs
first when its battery would not last the task (path length × :attr:`ChargePolicy.drain`, with
:attr:`ChargePolicy.reserve` kept to reach the dock).
"""

from __future__ import annotations

from dataclasses import dataclass


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

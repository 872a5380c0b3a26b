"""The simulator's own controls, which no real robot has (``/sim/…``): its battery, a kidnap,
the emergency stop. See :mod:`~..controls`."""

from __future__ import annotations

from ...model import Pose2D
from ..runner import RunnerPart


class SimControls(RunnerPart):
    def set_battery(self, percent: float) -> float:
        return self.runner.call(self.runner.simulator.set_battery, percent)

    def kidnap(self, true_pose: Pose2D) -> None:
        self.runner.call(self.runner.simulator.kidnap, true_pose)

    def emergency_stop(self, pressed: bool) -> None:
        self.runner.call(self.runner.simulator.emergency_stop, pressed)

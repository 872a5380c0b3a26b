"""The simulated robot's link: connected while its runner steps it."""

from __future__ import annotations

from ...backend import Link
from ..runner import RunnerPart
from ..simulator import Simulator


class SimLink(RunnerPart, Link):
    """Starting and stopping the simulation is connecting and disconnecting."""

    @property
    def connected(self) -> bool:
        return self.runner.running

    async def start(self) -> None:
        await self.runner.start()

    async def stop(self) -> None:
        await self.runner.stop()

    @property
    def simulator(self) -> Simulator:
        """The simulator now running (a reboot replaces it): what a ``Robot`` of it shows the
        sim tools and tests."""
        return self.runner.simulator

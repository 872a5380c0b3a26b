"""The simulated robot's link: connected while its runner steps it."""

from __future__ import annotations

from ...backend import Link
from .part import SimPart


class SimLink(SimPart, Link):
    """Starting and stopping the simulation is connecting and disconnecting."""

    @property
    def connected(self) -> bool:
        return self.runner.running

    async def start(self) -> None:
        await self.runner.start()

    async def stop(self) -> None:
        await self.runner.stop()

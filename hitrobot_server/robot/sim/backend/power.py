"""The simulated robot's battery and board, its shutdown and reboot (the runner's)."""

from __future__ import annotations

from ...backend import PowerBackend
from ...model import PowerStatus
from ..runner import RunnerPart


class SimPower(RunnerPart, PowerBackend):
    async def get_power_status(self) -> PowerStatus:
        return self.runner.call(self.runner.simulator.power_status)

    async def get_board_temperature(self) -> int:
        return self.runner.call(self.runner.simulator.board_temperature)

    async def power_off(self) -> None:
        await self.runner.power_off()

    async def reboot(self) -> None:
        await self.runner.reboot()

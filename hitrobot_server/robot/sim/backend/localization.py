"""Where the simulated robot believes it is, and its relocalization."""

from __future__ import annotations

from ...backend import LocalizationBackend
from ...model import ActionInfo, LocalizationMovement, Pose2D, Rect
from ..runner import RunnerPart


class SimLocalization(RunnerPart, LocalizationBackend):
    async def get_pose(self) -> Pose2D:
        return self.runner.call(lambda: self.runner.simulator.pose)

    async def set_pose(self, pose: Pose2D) -> None:
        await self.runner.change(self.runner.simulator.set_pose, pose)

    async def get_localization_enabled(self) -> bool:
        return self.runner.call(lambda: self.runner.simulator.localization_enabled)

    async def set_localization_enabled(self, enabled: bool) -> None:
        await self.runner.change(setattr, self.runner.simulator, "localization_enabled", enabled)

    async def get_localization_quality(self) -> int:
        return self.runner.call(lambda: self.runner.simulator.localization_quality)

    async def recover_localization(self, area: Rect | None = None,
                                   max_time_ms: int | None = None,
                                   movement: LocalizationMovement | None = None) -> ActionInfo:
        recover = self.runner.simulator.actions.recover_localization
        return self.runner.call(recover, area, max_time_ms, movement)

"""Where the simulated robot believes it is, and its relocalization."""

from __future__ import annotations

from ...backend import LocalizationBackend
from ...model import ActionInfo, LocalizationMovement, Pose2D, Rect
from .part import SimPart


class SimLocalization(SimPart, LocalizationBackend):
    async def get_pose(self) -> Pose2D:
        return self._call(lambda: self.simulator.pose)

    async def set_pose(self, pose: Pose2D) -> None:
        await self._change(self.simulator.set_pose, pose)

    async def get_localization_enabled(self) -> bool:
        return self._call(lambda: self.simulator.localization_enabled)

    async def set_localization_enabled(self, enabled: bool) -> None:
        await self._change(setattr, self.simulator, "localization_enabled", enabled)

    async def get_localization_quality(self) -> int:
        return self._call(lambda: self.simulator.localization_quality)

    async def recover_localization(self, area: Rect | None = None,
                                   max_time_ms: int | None = None,
                                   movement: LocalizationMovement | None = None) -> ActionInfo:
        recover = self.simulator.actions.recover_localization
        return self._call(recover, area, max_time_ms, movement)

"""``RestLocalization``: where the robot believes it is, over the Slamware REST API."""

from __future__ import annotations

from ..backend import BackendError, LocalizationBackend
from ..model import ActionInfo, LocalizationMovement, Pose2D, Rect
from . import paths, shapes
from .link import RestLink, finite_pose


class RestLocalization(LocalizationBackend):
    """The pose, the localization switch and quality, and relocalization actions."""

    def __init__(self, link: RestLink) -> None:
        self._link = link

    async def get_pose(self) -> Pose2D:
        return await self._link.get(paths.POSE, shapes.pose_from)

    async def get_odopose(self) -> Pose2D:
        """The odometry (dead-reckoning) pose; not part of :class:`LocalizationBackend`."""
        return await self._link.get(paths.ODOPOSE, shapes.pose_from)

    async def set_pose(self, pose: Pose2D) -> None:
        finite_pose(pose)
        await self._link.command("PUT", paths.POSE, shapes.pose3d_json(pose))

    async def get_localization_enabled(self) -> bool:
        return await self._link.boolean(paths.LOCALIZATION_ENABLE)

    async def set_localization_enabled(self, enabled: bool) -> None:
        await self._link.command("PUT", paths.LOCALIZATION_ENABLE, {"enable": bool(enabled)})

    async def get_localization_quality(self) -> int:
        return await self._link.get(paths.QUALITY,
                                    lambda v: round(shapes.number(v, "localization quality")))

    async def recover_localization(
        self,
        area: Rect | None = None,
        max_time_ms: int | None = None,
        movement: LocalizationMovement | None = None,
    ) -> ActionInfo:
        if max_time_ms is not None and max_time_ms <= 0:
            raise BackendError("max_time_ms must be positive")
        return await self._link.start_action(shapes.recover_request(area, max_time_ms, movement))

"""The Slamware node's map requests and services: syncing, clearing and switching the map,
localization on the map, virtual walls and tracks, and the composite map (``sync_get_stcm``,
``sync_set_stcm``)."""

from __future__ import annotations

from ...bus.errors import ServiceError
from ...bus.topics import Message
from ...robot.backend import BackendError
from ...robot.capabilities import Robot
from ...robot.model import ArtifactUsage, Line, MapKind
from ..ground import messages as m
from ..ground.memory import NotSaved
from ..ground.names import SLAMWARE_MAP_CLEARED, SLAMWARE_SYNC_MAP
from .fields import enum_field, line, lines, usage
from .map_copy import MapCopy
from .runner import Request, Runner
from .topics import PKG


class MapRequests:
    """The robot's map and its artifacts as the real node's request topics change them."""

    def __init__(self, runner: Runner, robot: Robot, map_copy: MapCopy):
        self.runner, self.robot, self.map_copy = runner, robot, map_copy

    def requests(self) -> list[Request]:
        return [
            (SLAMWARE_SYNC_MAP, f"{PKG}/SyncMapRequest", self._on_sync_map),
            ("clear_map", f"{PKG}/ClearMapRequest", self._on_clear_map),
            ("set_map_update", f"{PKG}/SetMapUpdateRequest", self._on_set_map_update),
            ("set_map_localization", f"{PKG}/SetMapLocalizationRequest", self._on_set_loc),
            ("add_line", f"{PKG}/AddLineRequest", self._on_add_line),
            ("add_lines", f"{PKG}/AddLinesRequest", self._on_add_lines),
            ("remove_line", f"{PKG}/RemoveLineRequest", self._on_remove_line),
            ("clear_lines", f"{PKG}/ClearLinesRequest", self._on_clear_lines),
            ("move_line", f"{PKG}/MoveLineRequest", self._on_move_line),
            ("move_lines", f"{PKG}/MoveLinesRequest", self._on_move_lines),
        ]

    def _on_sync_map(self, message: Message) -> None:
        self.map_copy.sync_requested = True

    def _on_clear_map(self, message: Message) -> None:
        kind = enum_field("kind.kind", message.msg["kind"]["kind"], MapKind)

        async def clear() -> str:
            await self.robot.maps.clear_map(kind)
            try:
                await self.map_copy.cleared()
            except NotSaved as exc:
                raise BackendError(f"the map was cleared, but {exc}") from None
            return SLAMWARE_MAP_CLEARED  # the map manager hears it: no saved map is loaded any more

        self.runner.run(message, "clear_map", clear)

    def _on_set_map_update(self, message: Message) -> None:
        msg = message.msg
        kind = enum_field("kind.kind", msg["kind"]["kind"], MapKind)
        self.runner.run(message, "set_map_update",
                        lambda: self.robot.maps.set_map_update(bool(msg["enabled"]), kind))

    def _on_set_loc(self, message: Message) -> None:
        enabled = bool(message.msg["enabled"])
        self.runner.run(message, "set_map_localization",
                        lambda: self.robot.localization.set_localization_enabled(enabled))

    def _on_add_line(self, message: Message) -> None:
        kind, ln = usage(message.msg), line(message.msg["line"], "line")
        self.runner.run(message, "add_line", lambda: self.robot.maps.add_lines(kind, [ln]))

    def _on_add_lines(self, message: Message) -> None:
        kind, new = usage(message.msg), lines(message.msg)
        self.runner.run(message, "add_lines", lambda: self.robot.maps.add_lines(kind, new))

    def _on_remove_line(self, message: Message) -> None:
        kind, line_id = usage(message.msg), int(message.msg["id"])

        async def remove() -> bool:
            if not await self.robot.maps.remove_line(kind, line_id):
                raise BackendError(f"no {kind.name.lower()} with id {line_id}")
            return True

        self.runner.run(message, "remove_line", remove)

    def _on_clear_lines(self, message: Message) -> None:
        kind = usage(message.msg)
        self.runner.run(message, "clear_lines", lambda: self.robot.maps.clear_lines(kind))

    def _on_move_line(self, message: Message) -> None:
        kind, ln = usage(message.msg), line(message.msg["line"], "line")
        self.runner.run(message, "move_line", lambda: self._move_lines(kind, [ln]))

    def _on_move_lines(self, message: Message) -> None:
        kind, moved = usage(message.msg), lines(message.msg)
        self.runner.run(message, "move_lines", lambda: self._move_lines(kind, moved))

    async def _move_lines(self, kind: ArtifactUsage, moved: list[Line]) -> bool:
        if not await self.robot.maps.move_lines(kind, moved):
            ids = ", ".join(str(ln.id) for ln in moved)
            raise BackendError(f"no {kind.name.lower()} with id(s) {ids}")
        return True

    # ------------------------------------------------------------------ services
    async def sync_get_stcm(self, request: dict) -> dict:
        try:
            return {"raw_stcm": await self.robot.maps.get_composite_map()}
        except BackendError as exc:
            raise ServiceError(f"sync_get_stcm: {exc}") from None

    async def sync_set_stcm(self, request: dict) -> dict:
        """The real node's steps, made safe: the map is checked completely first (a refused
        map changes nothing); then cancel, stop localization and mapping, load the composite
        map at the given pose (it replaces the old one, so no separate clear), localize again,
        resync the map copy. If the robot refuses the load, localization and mapping are put
        back as they were."""
        b = self.robot
        data = bytes(request["raw_stcm"])
        if not data:
            raise ServiceError("sync_set_stcm: field 'raw_stcm' is empty")
        pose = m.pose2d(request["robot_pose"])
        try:
            await b.maps.check_composite_map(data)
            localizing = await b.localization.get_localization_enabled()
            mapping = await b.maps.get_map_update(MapKind.EXPLORERMAP)
            await b.motion.cancel_action()
            await b.localization.set_localization_enabled(False)
            await b.maps.set_map_update(False, MapKind.EXPLORERMAP)
            try:
                await b.maps.set_composite_map(data, pose)
            except BackendError:
                await b.maps.set_map_update(mapping, MapKind.EXPLORERMAP)
                await b.localization.set_localization_enabled(localizing)
                raise
            await b.localization.set_localization_enabled(True)
        except BackendError as exc:
            raise ServiceError(f"sync_set_stcm: {exc}") from None
        self.map_copy.sync_requested = True
        return {}

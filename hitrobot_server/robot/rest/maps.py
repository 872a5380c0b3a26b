"""``RestMaps``: the robot's map, virtual lines, blocked areas, home and whole-map transfer over
the Slamware REST API, and the planner's view of them (:meth:`RestMaps.costmap`).

``set_blocked_areas`` becomes forbidden rectangle areas covering each polygon, marked by
metadata so only ours are replaced; ``add_lines`` cannot keep requested ids (the robot assigns
them).
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Sequence

import numpy as np

from .. import composite_map
from ..backend import BackendError, MapBackend, UnsupportedError
from ..model import ArtifactUsage, Line, MapKind, MapRegion, Point2D, Pose2D, Rect
from ..planning.costmap import Costmap, CostmapConfig, build_costmap
from ..planning.grid import GridSpec
from . import limits, mapformat, paths, shapes
from .link import RestLink, converted, finite_pose, http_error, parsed

log = logging.getLogger(__name__)


class RestMaps(MapBackend):
    """The explore map (the only map kind REST serves), lines, areas, home and stcm files."""

    def __init__(self, link: RestLink) -> None:
        self._link = link
        self._warned_missing: set[str] = set()
        self._blocked_lock = asyncio.Lock()
        self.blocked: tuple[tuple[Point2D, ...], ...] = ()
        """The blocked areas last sent, as polygons (the robot only keeps their cover)."""
        self.resolution = mapformat.DEFAULT_RESOLUTION
        """The last map's, which bounds the known area (:data:`.limits.MAX_MAP_CELLS`)."""

    # --- the explore map ---------------------------------------------------------------------

    async def get_known_area(self, kind: MapKind = MapKind.EXPLORERMAP) -> Rect:
        _explore_only(kind)
        area = await self._link.get(paths.KNOWN_AREA, shapes.rect_from)
        assert area is not None
        if max(area.width, 0.0) * max(area.height, 0.0) / self.resolution ** 2 \
                > limits.MAX_MAP_CELLS:
            raise self._link.refused(
                "GET", paths.KNOWN_AREA, f"a known area of {area.width:g} x {area.height:g} m "
                f"is over the bound of {limits.MAX_MAP_CELLS} cells at {self.resolution:g} m")
        return area

    async def get_map(
        self, area: Rect | None = None, kind: MapKind = MapKind.EXPLORERMAP
    ) -> MapRegion:
        _explore_only(kind)
        params = None
        if area is not None:
            params = {"min_x": repr(float(area.x)), "min_y": repr(float(area.y)),
                      "max_x": repr(float(area.x + area.width)),
                      "max_y": repr(float(area.y + area.height))}
        reply = await self._link.request("GET", paths.EXPLORE_MAP, params=params,
                                         timeout=self._link.bulk_timeout)
        region = None
        if reply.status != 404:  # some robots answer 404 while they have no map
            if not reply.ok:
                raise self._link.refused("GET", paths.EXPLORE_MAP, http_error(reply))
            try:
                region = await parsed(reply, lambda: mapformat.decode(reply.body))
            except mapformat.MapFormatError as exc:
                raise self._link.refused("GET", paths.EXPLORE_MAP, str(exc)) from None
            if region is not None:
                self.resolution = region.resolution
        self._link.answered("GET", paths.EXPLORE_MAP)
        if region is None:  # no map yet
            x, y = (area.x, area.y) if area is not None else (0.0, 0.0)
            region = MapRegion(x, y, mapformat.DEFAULT_RESOLUTION,
                               np.zeros((0, 0), dtype=np.uint8))
        return region

    async def clear_map(self, kind: MapKind = MapKind.EXPLORERMAP) -> None:
        _explore_only(kind)
        await self._link.command("DELETE", paths.MAPS)

    async def get_map_update(self, kind: MapKind = MapKind.EXPLORERMAP) -> bool:
        _explore_only(kind)
        return await self._link.boolean(paths.MAPPING_ENABLE)

    async def set_map_update(self, enabled: bool, kind: MapKind = MapKind.EXPLORERMAP) -> None:
        _explore_only(kind)
        await self._link.command("PUT", paths.MAPPING_ENABLE, {"enable": bool(enabled)})

    # --- virtual lines and blocked areas -----------------------------------------------------

    async def get_lines(self, usage: ArtifactUsage) -> list[Line]:
        path = paths.lines(usage)
        lines = await self._link.get(path, shapes.lines_from, missing_ok=True)
        if lines is None:
            if path not in self._warned_missing:
                self._warned_missing.add(path)
                log.warning("the robot has no %s (404); publishing none", path)
            return []
        return lines

    async def add_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> list[Line]:
        """POST the lines, then read them back: the robot ignores requested ids and assigns
        its own, so the returned lines carry the robot's ids."""
        lines = list(lines)
        if not lines:
            return []
        path = paths.lines(usage)
        before = {ln.id for ln in await self.get_lines(usage)}
        await self._link.command("POST", path, [shapes.line_json(ln) for ln in lines])
        fresh = [ln for ln in await self.get_lines(usage) if ln.id not in before]
        stored = []
        for wanted in lines:
            match = next((ln for ln in fresh if _same_segment(ln, wanted)), None)
            if match is not None:
                fresh.remove(match)
                stored.append(match)
        return stored + fresh if len(stored) < len(lines) else stored

    async def remove_line(self, usage: ArtifactUsage, line_id: int) -> bool:
        return await self._link.removal("DELETE", f"{paths.lines(usage)}/{int(line_id)}")

    async def clear_lines(self, usage: ArtifactUsage) -> None:
        await self._link.command("DELETE", paths.lines(usage))

    async def move_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        return await self._link.removal("PUT", paths.lines(usage),
                                        json=[shapes.line_json(ln) for ln in lines])

    async def set_blocked_areas(self, areas: Sequence[Sequence[Point2D]]) -> None:
        """Replace our forbidden rectangle areas with a cover of ``areas``.

        REST has no polygons; each one becomes rectangle areas of usage ``forbidden_area``
        (:func:`shapes.cover_polygon`: one for a rectangle, strips of 5 cm otherwise), tagged
        with :data:`shapes.BLOCKED_METADATA`. Areas without that tag (made by other tools) are
        left alone; ours from an earlier run are replaced."""
        path = f"{paths.RECTANGLE_AREAS}/{paths.FORBIDDEN_AREA}"
        covers = [shapes.cover_polygon(list(polygon)) for polygon in areas]
        self.blocked = tuple(tuple(polygon) for polygon in areas)
        async with self._blocked_lock:
            existing = await self._link.json("GET", path, missing_ok=True)
            if existing is None:
                raise UnsupportedError("the robot has no rectangle areas (firmware older than "
                                       "the REST API 1.1?): blocked areas cannot be sent")
            ours = converted(path, shapes.owned_area_ids, existing)
            for area_id in ours:
                await self._link.command("DELETE", f"{path}/{area_id}")
            for cover in covers:
                for start, end, half_width in cover:
                    await self._link.command("POST", path, shapes.rectangle_area_json(
                        start, end, half_width, shapes.BLOCKED_METADATA))

    # --- home and the whole map --------------------------------------------------------------

    async def get_home_pose(self) -> Pose2D | None:
        return await self._link.get(paths.HOMEPOSE, shapes.pose_from, missing_ok=True)

    async def set_home_pose(self, pose: Pose2D) -> None:
        finite_pose(pose)
        await self._link.command("PUT", paths.HOMEPOSE, shapes.pose3d_json(pose))

    async def get_composite_map(self) -> bytes:
        reply = await self._link.request("GET", paths.STCM, timeout=self._link.bulk_timeout)
        if not reply.ok:
            raise self._link.refused("GET", paths.STCM, http_error(reply))
        self._link.answered("GET", paths.STCM)
        return reply.body

    async def check_composite_map(self, data: bytes) -> None:
        """Our own container (what the simulator and sim-device serve) is checked completely;
        SLAMTEC's ``.stcm`` is proprietary and only the robot can judge it (its ``PUT`` refuses
        a bad file without touching the map)."""
        self._link.require_connection()
        if data[:len(composite_map.MAGIC)] == composite_map.MAGIC:
            try:
                composite_map.decode(data)
            except composite_map.CompositeMapError as exc:
                raise BackendError(f"invalid composite map: {exc}") from None
        elif not data:
            raise BackendError("the composite map is empty")

    async def set_composite_map(self, data: bytes, pose: Pose2D) -> None:
        """PUT the file unchanged (the robot then sits at the origin), then set the pose."""
        finite_pose(pose)
        await self._link.command("PUT", paths.STCM, data=bytes(data),
                                 timeout=self._link.bulk_timeout)
        await self._link.command("PUT", paths.POSE, shapes.pose3d_json(pose))

    async def install_map(self, explore: MapRegion | None, walls: Sequence[Line],
                          tracks: Sequence[Line], home: Pose2D | None, pose: Pose2D) -> None:
        """PUT as our composite-map container (what sim-device takes; SLAMTEC's ``.stcm`` is
        proprietary and cannot be written here), then set the pose."""
        await self.set_composite_map(composite_map.encode(composite_map.CompositeMap(
            explore, tuple(walls), tuple(tracks), home)), pose)

    # --- the planner's view ------------------------------------------------------------------

    async def costmap(self, area: Rect | None = None) -> Costmap:
        """The planner's view of the robot's map (the known area when ``area`` is None): its
        explore map, virtual walls and tracks and the blocked areas we sent."""
        region = await self.get_map(area)
        if region.cells.size == 0:
            raise BackendError("the robot has no map to plan on")
        spec = GridSpec(region.origin_x, region.origin_y, region.resolution,
                        region.width, region.height)
        return build_costmap(
            spec, region.cells >= 128, region.cells == 0, CostmapConfig(),
            walls=await self.get_lines(ArtifactUsage.VIRTUAL_WALL),
            blocked=self.blocked,
            tracks=await self.get_lines(ArtifactUsage.VIRTUAL_TRACK))


def _explore_only(kind: MapKind) -> None:
    if kind != MapKind.EXPLORERMAP:
        raise UnsupportedError(f"the REST API only serves the explore map, not {kind!r}")


def _same_segment(a: Line, b: Line, tol: float = 1e-3) -> bool:
    return (math.hypot(a.start.x - b.start.x, a.start.y - b.start.y) < tol
            and math.hypot(a.end.x - b.end.x, a.end.y - b.end.y) < tol)

"""The sim-device's virtual lines (ids chosen by the robot) and rectangle areas (kept here; the
forbidden ones are handed to the simulator as blocked areas, other usages are only stored)."""

from __future__ import annotations

from aiohttp import web

from ..model import ArtifactUsage, Line
from ..rest import paths, shapes
from ..sim.backend import SimBackend
from .replies import body_of, reply, text


class LineRoutes:
    """Virtual walls and tracks."""

    def __init__(self, backend: SimBackend) -> None:
        self.backend = backend

    def add_to(self, router: web.UrlDispatcher) -> None:
        lines = paths.LINES + "/{usage}"
        router.add_get(lines, self._get_lines, allow_head=False)
        router.add_post(lines, self._add_lines)
        router.add_put(lines, self._move_lines)
        router.add_delete(lines, self._clear_lines)
        router.add_delete(lines + r"/{line_id:\d+}", self._remove_line)

    @staticmethod
    def _line_usage(request: web.Request) -> ArtifactUsage:
        usage = paths.USAGE_OF.get(request.match_info["usage"])
        if usage is None:
            raise web.HTTPNotFound(text=f"no line usage {request.match_info['usage']!r}")
        return usage

    async def _get_lines(self, request: web.Request) -> web.Response:
        lines = await self.backend.maps.get_lines(self._line_usage(request))
        return reply([shapes.line_json(ln) for ln in lines])

    async def _add_lines(self, request: web.Request) -> web.Response:
        """The robot assigns ids: requested ones are ignored."""
        usage = self._line_usage(request)
        lines = shapes.lines_from(await body_of(request))
        await self.backend.maps.add_lines(usage, [Line(0, ln.start, ln.end) for ln in lines])
        return reply(True)

    async def _move_lines(self, request: web.Request) -> web.Response:
        usage = self._line_usage(request)
        lines = shapes.lines_from(await body_of(request))
        return reply(await self.backend.maps.move_lines(usage, lines))

    async def _clear_lines(self, request: web.Request) -> web.Response:
        await self.backend.maps.clear_lines(self._line_usage(request))
        return reply(True)

    async def _remove_line(self, request: web.Request) -> web.Response:
        usage = self._line_usage(request)
        return reply(await self.backend.maps.remove_line(usage, int(request.match_info["line_id"])))


class AreaRoutes:
    """Rectangle areas by usage, ids counted across usages as the robot does."""

    def __init__(self, backend: SimBackend) -> None:
        self.backend = backend
        self._areas: dict[str, dict[int, dict]] = {u: {} for u in paths.RECTANGLE_USAGES}
        self._next_area_id = 1

    def add_to(self, router: web.UrlDispatcher) -> None:
        areas = paths.RECTANGLE_AREAS + "/{usage}"
        router.add_get(areas, self._get_areas, allow_head=False)
        router.add_post(areas, self._add_area)
        router.add_delete(areas, self._clear_areas)
        router.add_put(areas + r"/{area_id:\d+}", self._put_area)
        router.add_delete(areas + r"/{area_id:\d+}", self._remove_area)

    def _area_table(self, request: web.Request) -> tuple[str, dict[int, dict]]:
        usage = request.match_info["usage"]
        if usage not in self._areas:
            raise web.HTTPNotFound(text=f"no rectangle-area usage {usage!r}")
        return usage, self._areas[usage]

    async def _areas_changed(self, usage: str) -> None:
        if usage == paths.FORBIDDEN_AREA:
            await self.backend.maps.set_blocked_areas([
                shapes.rectangle_corners(*shapes.rectangle_area_from(entry))
                for entry in self._areas[usage].values()])

    async def _get_areas(self, request: web.Request) -> web.Response:
        _usage, table = self._area_table(request)
        return reply(list(table.values()))

    async def _add_area(self, request: web.Request) -> web.Response:
        usage, table = self._area_table(request)
        body = shapes.obj(await body_of(request), "body")
        start, end, half_width = shapes.rectangle_area_from(body)
        if half_width < 0:
            raise shapes.ShapeError("half_width must not be negative")
        metadata = body.get("metadata") or {}
        area_id, self._next_area_id = self._next_area_id, self._next_area_id + 1
        table[area_id] = shapes.rectangle_area_json(start, end, half_width, metadata, area_id,
                                                    usage)
        await self._areas_changed(usage)
        return reply(True)

    async def _put_area(self, request: web.Request) -> web.Response:
        usage, table = self._area_table(request)
        area_id = int(request.match_info["area_id"])
        if area_id not in table:
            return text(404, f"no rectangle area {area_id}")
        body = shapes.obj(await body_of(request), "body")
        start, end, half_width = shapes.rectangle_area_from(body)
        metadata = body.get("metadata", table[area_id]["metadata"])
        table[area_id] = shapes.rectangle_area_json(start, end, half_width, metadata, area_id,
                                                    usage)
        await self._areas_changed(usage)
        return reply(True)

    async def _clear_areas(self, request: web.Request) -> web.Response:
        usage, table = self._area_table(request)
        table.clear()
        await self._areas_changed(usage)
        return reply(True)

    async def _remove_area(self, request: web.Request) -> web.Response:
        usage, table = self._area_table(request)
        found = table.pop(int(request.match_info["area_id"]), None) is not None
        if found:
            await self._areas_changed(usage)
        return reply(found)

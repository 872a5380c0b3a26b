"""The sim-device's SLAM endpoints: pose, localization and mapping switches, home, the explore
map and the whole map (``stcm``)."""

from __future__ import annotations

import math

from aiohttp import web

from ..model import Pose2D, Rect
from ..rest import mapformat, paths, shapes
from ..sim.backend import SimBackend
from .replies import body_of, empty, enabler, getter, reply, text


class SlamRoutes:
    """Where the robot is and what it has mapped."""

    def __init__(self, backend: SimBackend) -> None:
        self.backend = backend

    def add_to(self, router: web.UrlDispatcher) -> None:
        b = self.backend
        get, put, delete = router.add_get, router.add_put, router.add_delete
        get(paths.POSE, getter(b.localization.get_pose, shapes.pose3d_json), allow_head=False)
        put(paths.POSE, self._set_pose)
        get(paths.ODOPOSE, getter(b.localization.get_pose, shapes.pose3d_json), allow_head=False)
        get(paths.QUALITY, getter(b.localization.get_localization_quality, int), allow_head=False)
        get(paths.LOCALIZATION_ENABLE, getter(b.localization.get_localization_enabled, bool),
            allow_head=False)
        put(paths.LOCALIZATION_ENABLE, enabler(b.localization.set_localization_enabled))
        get(paths.MAPPING_ENABLE, getter(b.maps.get_map_update, bool), allow_head=False)
        put(paths.MAPPING_ENABLE, enabler(b.maps.set_map_update))
        get(paths.HOMEPOSE, self._home_pose, allow_head=False)
        put(paths.HOMEPOSE, self._set_home_pose)
        get(paths.KNOWN_AREA, getter(b.maps.get_known_area, shapes.rect_json), allow_head=False)
        get(paths.EXPLORE_MAP, self._explore_map, allow_head=False)
        get(paths.STCM, self._get_stcm, allow_head=False)
        put(paths.STCM, self._put_stcm)
        delete(paths.MAPS, self._clear_map)

    async def _set_pose(self, request: web.Request) -> web.Response:
        try:
            pose = shapes.pose_from(await body_of(request))
        except ValueError:
            return text(400, "Invalid Argument")
        await self.backend.localization.set_pose(pose)
        return empty()

    async def _home_pose(self, request: web.Request) -> web.Response:
        pose = await self.backend.maps.get_home_pose()
        return text(404, "Home dock not found") if pose is None else reply(
            shapes.pose3d_json(pose))

    async def _set_home_pose(self, request: web.Request) -> web.Response:
        await self.backend.maps.set_home_pose(shapes.pose_from(await body_of(request)))
        return reply(True)

    async def _explore_map(self, request: web.Request) -> web.Response:
        keys = ("min_x", "min_y", "max_x", "max_y")
        given = [k for k in keys if k in request.query]
        area = None
        if given:
            if len(given) != len(keys):
                return text(400, "min_x, min_y, max_x and max_y go together")
            try:
                x0, y0, x1, y1 = (float(request.query[k]) for k in keys)
            except ValueError:
                return text(400, "map bounds must be numbers")
            if not all(math.isfinite(v) for v in (x0, y0, x1, y1)):
                return text(400, "map bounds must be finite")
            area = Rect(x0, y0, x1 - x0, y1 - y0)
        region = await self.backend.maps.get_map(area)
        return web.Response(body=mapformat.encode(region), content_type="application/octet-stream")

    async def _get_stcm(self, request: web.Request) -> web.Response:
        data = await self.backend.maps.get_composite_map()
        return web.Response(body=data, content_type="application/octet-stream")

    async def _put_stcm(self, request: web.Request) -> web.Response:
        """Load the map; like the robot, the pose is reset to the origin (clients set it)."""
        data = await request.read()
        if not data:
            return text(400, "an stcm body is required")
        await self.backend.maps.set_composite_map(data, Pose2D(0.0, 0.0, 0.0))
        return empty()

    async def _clear_map(self, request: web.Request) -> web.Response:
        await self.backend.maps.clear_map()
        return empty()

"""The sim-device: the built-in simulator behind the Slamware REST API, over real HTTP.

``hitrobot-server sim-device --port 1448`` (or :class:`SimDevice` in-process) serves the
endpoints :class:`~.client.SlamwareRestBackend` uses, the way a robot does: paths with literal
``:`` segments, bare JSON booleans and numbers, octet-stream maps with the 36-byte header, 404
from ``actions/:current`` when idle, action status 0/1/3/4 with result 0/-1/-2, finished
actions read back as gravestones (no name, no stage), line ids chosen by the robot (requested
ids are ignored). It binds 127.0.0.1 by default.

It is a test double, not an emulator of every endpoint: see :data:`NOT_EMULATED`. Its command
line is :mod:`hitrobot_server.commands.sim_device`.
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Awaitable, Callable
from typing import Any

import orjson
from aiohttp import web

from ... import __version__
from ..backend import ACTION_PREFIX, BackendError, NotConnectedError, UnsupportedError
from ..model import ActionDirection, ActionInfo, Line, Pose2D, Rect
from ..sim.backend import SimBackend
from ..sim.simulator import Simulator
from . import mapformat, paths, shapes

log = logging.getLogger(__name__)

NOT_EMULATED = (
    "multi-floor, delivery, POIs, home docks, events, IMU, parameters, network, statistics, "
    "strategies, search_path, loop closure, hibernate/wakeup and the shutdown/restart "
    "intervals (shutdown is immediate, every restart mode is a reboot); MoveToTag, "
    "BackOffFromTag and other "
    "vendor actions; GoHome 'no_dock'; the real .stcm format (the simulator's own composite "
    "map bytes are served instead); a separate odometry pose (odopose is the localized pose); "
    "forbidden rectangle areas are honoured, other rectangle-area usages are only stored"
)

ACTION_NAMES = ("MoveToAction", "SeriesMoveToAction", "MoveByAction", "RotateToAction",
                "RotateAction", "GoHomeAction", "RecoverLocalizationAction")

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


def reply(value: Any, status: int = 200) -> web.Response:
    """A JSON answer; bare booleans and numbers are sent bare, as the robot does."""
    return web.Response(body=orjson.dumps(value), status=status,
                        content_type="application/json")


def text(status: int, message: str) -> web.Response:
    return web.Response(text=message, status=status)


def empty() -> web.Response:
    return web.Response(status=200)


async def body_of(request: web.Request) -> Any:
    raw = await request.read()
    if not raw.strip():
        raise shapes.ShapeError("a JSON body is required")
    return orjson.loads(raw)


class SimDevice:
    """One simulated robot serving REST on ``address:port`` (0 = any free port).

    ``start`` and ``stop`` may alternate: stopping closes the listener and every connection and
    pauses the simulator, like a robot dropping off the network; starting again binds the same
    port and resumes where it was."""

    def __init__(self, simulator: Simulator, *, address: str = "127.0.0.1", port: int = 1448,
                 time_scale: float = 1.0, rate_hz: float = 20.0):
        self.backend = SimBackend(simulator, rate_hz=rate_hz, time_scale=time_scale)
        self.address = address
        self.port = port
        self.requests = 0
        self._runner: web.AppRunner | None = None
        self._areas: dict[str, dict[int, dict]] = {u: {} for u in paths.RECTANGLE_USAGES}
        self._next_area_id = 1
        self._power: asyncio.Task[None] | None = None

    @property
    def simulator(self) -> Simulator:
        """The simulator now serving (a reboot replaces it)."""
        return self.backend.simulator

    @property
    def url(self) -> str:
        return f"http://{self.address}:{self.port}"

    @property
    def running(self) -> bool:
        return self._runner is not None

    async def start(self) -> None:
        await self.backend.start()
        await self._listen()

    async def stop(self) -> None:
        power, self._power = self._power, None
        if power is not None and power is not asyncio.current_task():
            power.cancel()
        await self._close()
        await self.backend.stop()

    async def _listen(self) -> None:
        if self._runner is not None:
            return
        runner = web.AppRunner(self._app(), access_log=None, shutdown_timeout=1.0,
                               handle_signals=False)
        await runner.setup()
        site = web.TCPSite(runner, self.address, self.port, reuse_address=True)
        try:
            await site.start()
        except BaseException:
            await runner.cleanup()
            await self.backend.stop()
            raise
        self.port = runner.addresses[0][1]
        self._runner = runner

    async def _close(self) -> None:
        runner, self._runner = self._runner, None
        if runner is not None:
            await runner.cleanup()

    # --- application -------------------------------------------------------------------------

    def _app(self) -> web.Application:
        app = web.Application(middlewares=[self._errors], client_max_size=64 * 1024 * 1024)
        b = self.backend
        r = app.router
        get, put, post, delete = r.add_get, r.add_put, r.add_post, r.add_delete

        get(paths.CAPABILITIES, self._capabilities, allow_head=False)
        get(paths.POWER_STATUS, self._getter(b.get_power_status, shapes.power_json),
            allow_head=False)
        get(paths.ROBOT_INFO, self._getter(b.get_device_info, shapes.device_info_json),
            allow_head=False)
        get(paths.ROBOT_HEALTH, self._getter(b.get_health, shapes.health_json), allow_head=False)
        delete(paths.ROBOT_HEALTH + r"/{code:-?\d+}", self._clear_health)
        post(paths.POWER_SHUTDOWN, self._shutdown)
        post(paths.POWER_RESTART_MODULE, self._restart)
        get(paths.LASERSCAN, self._getter(b.get_laser_scan, shapes.laser_scan_json),
            allow_head=False)

        get(paths.POSE, self._getter(b.get_pose, shapes.pose3d_json), allow_head=False)
        put(paths.POSE, self._set_pose)
        get(paths.ODOPOSE, self._getter(b.get_pose, shapes.pose3d_json), allow_head=False)
        get(paths.QUALITY, self._getter(b.get_localization_quality, int), allow_head=False)
        get(paths.LOCALIZATION_ENABLE, self._getter(b.get_localization_enabled, bool),
            allow_head=False)
        put(paths.LOCALIZATION_ENABLE, self._enabler(b.set_localization_enabled))
        get(paths.MAPPING_ENABLE, self._getter(b.get_map_update, bool), allow_head=False)
        put(paths.MAPPING_ENABLE, self._enabler(b.set_map_update))
        get(paths.HOMEPOSE, self._home_pose, allow_head=False)
        put(paths.HOMEPOSE, self._set_home_pose)
        get(paths.KNOWN_AREA, self._getter(b.get_known_area, shapes.rect_json), allow_head=False)
        get(paths.EXPLORE_MAP, self._explore_map, allow_head=False)
        get(paths.STCM, self._get_stcm, allow_head=False)
        put(paths.STCM, self._put_stcm)
        delete(paths.MAPS, self._clear_map)

        get(paths.ACTION_FACTORIES, self._factories, allow_head=False)
        post(paths.ACTIONS, self._create_action)
        get(paths.CURRENT_ACTION, self._current_action, allow_head=False)
        delete(paths.CURRENT_ACTION, self._cancel_action)
        get(paths.ACTIONS + r"/{action_id:\d+}", self._action, allow_head=False)
        get(paths.PATH, self._getter(b.get_remaining_path, shapes.path_json), allow_head=False)
        get(paths.MILESTONES, self._getter(b.get_remaining_milestones, shapes.path_json),
            allow_head=False)
        get(paths.SPEED, self._speed, allow_head=False)

        lines = paths.LINES + "/{usage}"
        get(lines, self._get_lines, allow_head=False)
        post(lines, self._add_lines)
        put(lines, self._move_lines)
        delete(lines, self._clear_lines)
        delete(lines + r"/{line_id:\d+}", self._remove_line)

        areas = paths.RECTANGLE_AREAS + "/{usage}"
        get(areas, self._get_areas, allow_head=False)
        post(areas, self._add_area)
        delete(areas, self._clear_areas)
        put(areas + r"/{area_id:\d+}", self._put_area)
        delete(areas + r"/{area_id:\d+}", self._remove_area)
        return app

    @web.middleware
    async def _errors(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        """Robot-like failures: 503 while the simulator is paused, 404 for what it lacks,
        400 with the reason for anything it refuses or cannot parse."""
        self.requests += 1
        try:
            return await handler(request)
        except web.HTTPException:
            raise
        except NotConnectedError as exc:
            return text(503, str(exc))
        except UnsupportedError as exc:
            return text(404, str(exc))
        except (BackendError, ValueError) as exc:
            return text(400, str(exc) or type(exc).__name__)

    @staticmethod
    def _getter(fetch: Callable[[], Awaitable[Any]], encode: Callable[[Any], Any]) -> Handler:
        async def handle(request: web.Request) -> web.Response:
            return reply(encode(await fetch()))

        return handle

    @staticmethod
    def _enabler(apply: Callable[[bool], Awaitable[None]]) -> Handler:
        async def handle(request: web.Request) -> web.Response:
            body = shapes.obj(await body_of(request), "body")
            await apply(shapes.boolean(body.get("enable"), "enable"))
            return reply(True)

        return handle

    # --- system ------------------------------------------------------------------------------

    async def _capabilities(self, request: web.Request) -> web.Response:
        up = self.backend.connected
        return reply([{"name": name, "version": __version__, "enabled": up}
                      for name in ("slamware.agent.core", "slamware.agent.platform")])

    def _after_reply(self, work: Callable[[], Awaitable[None]]) -> None:
        async def later() -> None:
            await asyncio.sleep(0.05)  # let the answer go out first
            await work()

        if self._power is None or self._power.done():
            self._power = asyncio.get_running_loop().create_task(later(), name="device-power")

    async def _shutdown(self, request: web.Request) -> web.Response:
        """Off the network for good (until :meth:`start`)."""
        if not self.backend.connected:
            raise NotConnectedError("the simulator is not running")

        async def off() -> None:
            await self._close()
            await self.backend.power_off()

        self._after_reply(off)
        return reply(True)

    async def _restart(self, request: web.Request) -> web.Response:
        """Off the network now, back after the simulator's reboot delay with a fresh robot."""
        body = shapes.obj(await body_of(request), "body")
        if body.get("mode") not in ("RestartModeSoft", "RestartModeHard", "RestartModeBase"):
            return text(400, "mode must be RestartModeSoft, RestartModeHard or RestartModeBase")
        if not self.backend.connected:
            raise NotConnectedError("the simulator is not running")

        async def restart() -> None:
            await self._close()
            await self.backend.reboot()
            await asyncio.sleep(self.backend.reboot_delay)
            await self._listen()

        self._after_reply(restart)
        return reply(True)

    async def _clear_health(self, request: web.Request) -> web.Response:
        if await self.backend.clear_health_error(int(request.match_info["code"])):
            return empty()
        return text(400, "Invalid Error Code")

    async def _speed(self, request: web.Request) -> web.Response:
        return reply(shapes.speed_json((await self.backend.get_odometry()).twist))

    # --- slam --------------------------------------------------------------------------------

    async def _set_pose(self, request: web.Request) -> web.Response:
        try:
            pose = shapes.pose_from(await body_of(request))
        except ValueError:
            return text(400, "Invalid Argument")
        await self.backend.set_pose(pose)
        return empty()

    async def _home_pose(self, request: web.Request) -> web.Response:
        pose = await self.backend.get_home_pose()
        return text(404, "Home dock not found") if pose is None else reply(
            shapes.pose3d_json(pose))

    async def _set_home_pose(self, request: web.Request) -> web.Response:
        await self.backend.set_home_pose(shapes.pose_from(await body_of(request)))
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
        region = await self.backend.get_map(area)
        return web.Response(body=mapformat.encode(region), content_type="application/octet-stream")

    async def _get_stcm(self, request: web.Request) -> web.Response:
        data = await self.backend.get_composite_map()
        return web.Response(body=data, content_type="application/octet-stream")

    async def _put_stcm(self, request: web.Request) -> web.Response:
        """Load the map; like the robot, the pose is reset to the origin (clients set it)."""
        data = await request.read()
        if not data:
            return text(400, "an stcm body is required")
        await self.backend.set_composite_map(data, Pose2D(0.0, 0.0, 0.0))
        return empty()

    async def _clear_map(self, request: web.Request) -> web.Response:
        await self.backend.clear_map()
        return empty()

    # --- motion ------------------------------------------------------------------------------

    async def _factories(self, request: web.Request) -> web.Response:
        return reply([{"action_name": ACTION_PREFIX + name} for name in ACTION_NAMES])

    async def _create_action(self, request: web.Request) -> web.Response:
        try:
            body = shapes.obj(await body_of(request), "body")
            info = await self._start(body)
        except (BackendError, ValueError) as exc:
            return text(400, f"Can not create action: {exc}")
        return reply(shapes.action_json(info))

    async def _start(self, body: Any) -> ActionInfo:
        b = self.backend
        name = body.get("action_name")
        options = shapes.obj(body.get("options") or {}, "options")
        short = name.removeprefix(ACTION_PREFIX) if isinstance(name, str) else ""
        if not isinstance(name, str) or not name.startswith(ACTION_PREFIX) \
                or short not in ACTION_NAMES:
            raise shapes.ShapeError(f"unknown action {name!r}")
        move, yaw = shapes.move_options_from(options.get("move_options"))
        if short == "MoveToAction":
            return await b.move_to([shapes.point_from(options.get("target"), "target")], move,
                                   yaw)
        if short == "SeriesMoveToAction":
            raw = shapes.array(options.get("targets"), "targets")
            if not raw:
                raise shapes.ShapeError("targets must not be empty")
            targets = [shapes.point_from(t, f"targets[{i}]") for i, t in enumerate(raw)]
            return await b.move_to(targets, move, yaw)
        if short == "MoveByAction":
            duration = shapes.number(options.get("duration", 500), "duration") / 1000.0
            if "direction" in options:
                raw_direction = shapes.integer(options["direction"], "direction")
                try:
                    direction = ActionDirection(raw_direction)
                except ValueError:
                    raise shapes.ShapeError(f"direction must be 0-3, got {raw_direction}") \
                        from None
                return await b.move_by_direction(direction, move, duration)
            if "theta" in options:
                return await b.move_by_theta(shapes.number(options["theta"], "theta"), move,
                                             duration)
            raise shapes.ShapeError("MoveByAction needs a direction or a theta")
        if short in ("RotateToAction", "RotateAction"):
            angle = shapes.number(options.get("angle"), "angle")
            if short == "RotateToAction":
                return await b.rotate_to(angle, move)
            return await b.rotate(angle, move)
        if short == "GoHomeAction":
            home = shapes.obj(options.get("gohome_options") or {}, "gohome_options")
            move, _ = shapes.move_options_from(home.get("move_options"))
            return await b.go_home(move)
        # RecoverLocalizationAction
        area = None if options.get("area") is None else shapes.rect_from(options["area"], "area")
        reloc = shapes.obj(options.get("relocalization_options") or {},
                           "relocalization_options")
        max_time = reloc.get("max_recover_time")
        return await b.recover_localization(
            area, None if max_time is None else shapes.integer(max_time, "max_recover_time"),
            shapes.movement_from(reloc.get("recover_movement_type")))

    async def _current_action(self, request: web.Request) -> web.Response:
        action = await self.backend.get_current_action()
        if action is None:
            return text(404, "Action Not Found")
        return reply(shapes.action_json(action))

    async def _cancel_action(self, request: web.Request) -> web.Response:
        await self.backend.cancel_action()
        return empty()

    async def _action(self, request: web.Request) -> web.Response:
        action = await self.backend.get_action(int(request.match_info["action_id"]))
        if action is None:
            return text(404, "Action Not Found")
        data = shapes.action_json(action)
        if action.done:  # a finished action reads back as a gravestone
            data = {"action_id": data["action_id"], "state": data["state"]}
        return reply(data)

    # --- artifacts ---------------------------------------------------------------------------

    @staticmethod
    def _line_usage(request: web.Request):
        usage = paths.USAGE_OF.get(request.match_info["usage"])
        if usage is None:
            raise web.HTTPNotFound(text=f"no line usage {request.match_info['usage']!r}")
        return usage

    async def _get_lines(self, request: web.Request) -> web.Response:
        lines = await self.backend.get_lines(self._line_usage(request))
        return reply([shapes.line_json(ln) for ln in lines])

    async def _add_lines(self, request: web.Request) -> web.Response:
        """The robot assigns ids: requested ones are ignored."""
        usage = self._line_usage(request)
        lines = shapes.lines_from(await body_of(request))
        await self.backend.add_lines(usage, [Line(0, ln.start, ln.end) for ln in lines])
        return reply(True)

    async def _move_lines(self, request: web.Request) -> web.Response:
        usage = self._line_usage(request)
        lines = shapes.lines_from(await body_of(request))
        return reply(await self.backend.move_lines(usage, lines))

    async def _clear_lines(self, request: web.Request) -> web.Response:
        await self.backend.clear_lines(self._line_usage(request))
        return reply(True)

    async def _remove_line(self, request: web.Request) -> web.Response:
        usage = self._line_usage(request)
        return reply(await self.backend.remove_line(usage, int(request.match_info["line_id"])))

    def _area_table(self, request: web.Request) -> tuple[str, dict[int, dict]]:
        usage = request.match_info["usage"]
        if usage not in self._areas:
            raise web.HTTPNotFound(text=f"no rectangle-area usage {usage!r}")
        return usage, self._areas[usage]

    async def _areas_changed(self, usage: str) -> None:
        if usage == paths.FORBIDDEN_AREA:
            await self.backend.set_blocked_areas([
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

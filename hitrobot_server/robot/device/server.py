"""``SimDevice``: the sim-device's listener (started, stopped like a robot dropping off the
network), its robot-like errors and its system endpoints (identity, health, power)."""

from __future__ import annotations

import asyncio
from collections import Counter
from collections.abc import Awaitable, Callable

from aiohttp import web

from ... import __version__
from ..backend import BackendError, NotConnectedError, UnsupportedError
from ..rest import paths, shapes
from ..sim.backend import SimBackend
from ..sim.simulator import Simulator
from .actions import ActionRoutes
from .artifacts import AreaRoutes, LineRoutes
from .replies import Handler, body_of, empty, getter, reply, text
from .slam import SlamRoutes

NOT_EMULATED = (
    "multi-floor, delivery, POIs, home docks, events, IMU, parameters, network, statistics, "
    "strategies, search_path, loop closure, hibernate/wakeup and the shutdown/restart "
    "intervals (shutdown is immediate, every restart mode is a reboot); MoveToTag, "
    "BackOffFromTag and other "
    "vendor actions; GoHome 'no_dock'; the real .stcm format (the simulator's own composite "
    "map bytes are served instead); a separate odometry pose (odopose is the localized pose); "
    "forbidden rectangle areas are honoured, other rectangle-area usages are only stored"
)


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
        self.hits: Counter[str] = Counter()  # requests by path (what a server polls, for tests)
        self._runner: web.AppRunner | None = None
        self._routes = (SlamRoutes(self.backend), ActionRoutes(self.backend),
                        LineRoutes(self.backend), AreaRoutes(self.backend))
        """The endpoint groups after the system ones (the rectangle areas live in theirs, so
        they outlast a stop and start of the listener, as on the robot)."""
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
        await self.backend.link.start()
        await self._listen()

    async def stop(self) -> None:
        power, self._power = self._power, None
        if power is not None and power is not asyncio.current_task():
            power.cancel()
        await self._close()
        await self.backend.link.stop()

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
            await self.backend.link.stop()
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
        sensors = self.backend.sensors
        r = app.router
        get, post = r.add_get, r.add_post

        get(paths.CAPABILITIES, self._capabilities, allow_head=False)
        get(paths.POWER_STATUS, getter(self.backend.power.get_power_status, shapes.power_json),
            allow_head=False)
        get(paths.ROBOT_INFO, getter(sensors.get_device_info, shapes.device_info_json),
            allow_head=False)
        get(paths.ROBOT_HEALTH, getter(sensors.get_health, shapes.health_json), allow_head=False)
        r.add_delete(paths.ROBOT_HEALTH + r"/{code:-?\d+}", self._clear_health)
        post(paths.POWER_SHUTDOWN, self._shutdown)
        post(paths.POWER_RESTART_MODULE, self._restart)
        get(paths.LASERSCAN, getter(sensors.get_laser_scan, shapes.laser_scan_json),
            allow_head=False)
        for routes in self._routes:
            routes.add_to(r)
        return app

    @web.middleware
    async def _errors(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        """Robot-like failures: 503 while the simulator is paused, 404 for what it lacks,
        400 with the reason for anything it refuses or cannot parse."""
        self.requests += 1
        self.hits[request.path] += 1
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

    # --- system ------------------------------------------------------------------------------

    async def _capabilities(self, request: web.Request) -> web.Response:
        up = self.backend.link.connected
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
        if not self.backend.link.connected:
            raise NotConnectedError("the simulator is not running")

        async def off() -> None:
            await self._close()
            await self.backend.power.power_off()

        self._after_reply(off)
        return reply(True)

    async def _restart(self, request: web.Request) -> web.Response:
        """Off the network now, back after the simulator's reboot delay with a fresh robot."""
        body = shapes.obj(await body_of(request), "body")
        if body.get("mode") not in ("RestartModeSoft", "RestartModeHard", "RestartModeBase"):
            return text(400, "mode must be RestartModeSoft, RestartModeHard or RestartModeBase")
        if not self.backend.link.connected:
            raise NotConnectedError("the simulator is not running")

        async def restart() -> None:
            await self._close()
            await self.backend.power.reboot()
            await asyncio.sleep(self.backend.runner.reboot_delay)
            await self._listen()

        self._after_reply(restart)
        return reply(True)

    async def _clear_health(self, request: web.Request) -> web.Response:
        if await self.backend.sensors.clear_health_error(int(request.match_info["code"])):
            return empty()
        return text(400, "Invalid Error Code")


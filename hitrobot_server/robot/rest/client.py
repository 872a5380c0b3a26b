"""``SlamwareRestBackend``: a real Slamware robot through its REST API (port 1448).

Each :class:`~hitrobot_server.robot.backend.RobotBackend` method is one or a few HTTP calls
(see :mod:`.paths`). Connection handling follows ``slamware_ros_sdk_server_node``: a background
task connects (``GET capabilities`` until the core agent is enabled) and, whenever the robot is
lost, waits ``reconn_wait_ms`` and tries again, forever. While it is not connected
:attr:`connected` is False and every call raises :class:`NotConnectedError` without touching
the network; the node keeps serving its clients and resumes publishing on reconnect.

The robot counts as lost when a connection fails (refused, reset, unreachable) or when nothing
has answered for twice the request timeout. HTTP errors (400, 404 where it is not a normal
answer, 500) and ``false`` replies from setters become :class:`BackendError` with the method,
path and the robot's own text.

Where REST and the interface differ (see the README's real-robot section):

* ``set_velocity`` is emulated with short ``MoveByAction`` actions (direction or heading, with a
  speed ratio);
* ``set_blocked_areas`` becomes forbidden rectangle areas covering each polygon, marked by
  metadata so only ours are replaced;
* ``add_lines`` cannot keep requested ids (the robot assigns them);
* ``APPENDING`` is emulated by re-sending the remaining milestones plus the new targets;
* basic sensors and the board temperature are not in the REST API: none and 0;
* ``MoveOptions.planning_area`` has no REST form and is ignored by the robot;
* ``compute_path`` (plan without moving) has no REST form: the server plans on the robot's map
  itself; ``RETURN_UNREACHABLE_DIRECTLY`` has none either: the target is checked on that map
  before the move is sent;
* a move the robot reports as a success but that ended out of tolerance of its target is
  reported as FAILED (``get_action``).
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import math
import time
from collections.abc import Callable, Sequence
from typing import Any, TypeVar
from urllib.parse import urlsplit

import numpy as np

from ... import __version__
from .. import composite_map
from ..backend import BackendError, NotConnectedError, RobotBackend, UnsupportedError
from ..model import (
    ActionDirection,
    ActionInfo,
    ActionResult,
    ArtifactUsage,
    BasicSensorInfo,
    BasicSensorValue,
    DeviceInfo,
    HealthInfo,
    LaserScan,
    Line,
    LocalizationMovement,
    MapKind,
    MapRegion,
    MoveOptionFlag,
    MoveOptions,
    Odometry,
    Point2D,
    Pose2D,
    PowerStatus,
    Rect,
)
from ..sim.costmap import Costmap, CostmapConfig, build_costmap
from ..sim.grid import GridSpec
from ..sim.navigation import arrival_tolerance, path_search
from ..sim.planner import run_in_slices
from . import mapformat, paths, shapes
from .http import Reply, RestHttp, TransportError

log = logging.getLogger(__name__)

T = TypeVar("T")

TELEMETRY_TIMEOUT = 1.5
"""Seconds for state reads (pose, scan, status): real clients use 1.5-2 s."""
CONTROL_TIMEOUT = 8.0
"""Seconds for commands and configuration."""
BULK_TIMEOUT = 30.0
"""Seconds for maps and stcm files, which can be large."""
MANUAL_HOLD = 0.25
"""Seconds one ``set_velocity`` keeps the robot moving (the MoveBy ``duration``): short, so the
robot stops soon after the last command (``/cmd_vel`` publishers send at 10 Hz or more)."""
MANUAL_LINEAR = 0.7
MANUAL_ANGULAR = 1.8
"""Nominal full manual speeds (m/s, rad/s): a twist's speed ratio is measured against them."""
MOVE_ACTIONS = (shapes.MOVE_TO, shapes.SERIES_MOVE_TO)
ACTION_HISTORY = 20
"""Moves whose targets are remembered for the arrival check (the robot keeps 20 actions)."""
ARRIVAL_SLACK = 0.05
"""Metres of localization jitter allowed beyond a move's tolerance before its success is
called a failure."""


class SlamwareRestBackend(RobotBackend):
    """A Slamware robot at ``url`` (``http://192.168.11.1:1448``)."""

    def __init__(
        self,
        url: str,
        reconn_wait_ms: int = 3000,
        *,
        timeout: float = TELEMETRY_TIMEOUT,
        control_timeout: float = CONTROL_TIMEOUT,
        bulk_timeout: float = BULK_TIMEOUT,
    ):
        parts = urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.netloc:
            raise ValueError(f"not a Slamware REST URL: {url!r} (expected http://HOST:PORT)")
        if reconn_wait_ms <= 0 or timeout <= 0 or control_timeout <= 0 or bulk_timeout <= 0:
            raise ValueError("reconn_wait_ms and the timeouts must be positive")
        self.url = f"{parts.scheme}://{parts.netloc}{parts.path.rstrip('/')}"
        self._reconn_wait = reconn_wait_ms / 1000.0
        self._timeout = timeout
        self._control_timeout = control_timeout
        self._bulk_timeout = bulk_timeout
        self._http = RestHttp(self.url)
        self._connected = False
        self._task: asyncio.Task[None] | None = None
        self._lost: asyncio.Event | None = None
        self._last_ok = 0.0
        self._warned_missing: set[str] = set()
        self._blocked_lock = asyncio.Lock()
        self._manual: tuple[int, tuple, float] | None = None
        self._blocked: tuple[tuple[Point2D, ...], ...] = ()
        self._moves: dict[int, tuple[Point2D, float] | ActionInfo] = {}  # target or verdict

    # --- connection --------------------------------------------------------------------------

    @property
    def connected(self) -> bool:
        return self._connected

    async def start(self) -> None:
        if self._task is None or self._task.done():
            self._lost = asyncio.Event()
            self._task = asyncio.get_running_loop().create_task(
                self._keep_connected(), name="slamware-rest-connect")

    async def stop(self) -> None:
        task, self._task = self._task, None
        self._connected = False
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        await self._http.close()

    async def _keep_connected(self) -> None:
        warned = False
        while True:
            try:
                ready, why = await self._probe()
            except TransportError as exc:
                ready, why = False, str(exc)
            if ready:
                warned = False
                self._last_ok = time.monotonic()
                self._connected = True
                log.info("connected to the Slamware robot at %s", self.url)
                assert self._lost is not None
                await self._lost.wait()
                self._lost.clear()
                await self._http.reset()
                warned = True  # the loss was logged; stay quiet until the robot is back
            elif not warned:
                log.warning("Slamware robot at %s not reachable (%s); retrying every %d ms",
                            self.url, why, round(self._reconn_wait * 1000))
                warned = True
            await asyncio.sleep(self._reconn_wait)

    async def _probe(self) -> tuple[bool, str]:
        """Poll ``capabilities`` as the manual asks; a robot without it is probed with
        ``robot/info``."""
        reply = await self._http.request("GET", paths.CAPABILITIES, timeout=self._timeout)
        if reply.status == 404:
            reply = await self._http.request("GET", paths.ROBOT_INFO, timeout=self._timeout)
            return reply.ok, f"robot/info answered HTTP {reply.status}"
        if not reply.ok:
            return False, f"capabilities answered HTTP {reply.status}"
        try:
            ready = shapes.core_ready(reply.json())
        except ValueError as exc:
            return False, f"capabilities: {exc}"
        return ready, "the core agent is still starting"

    def _lose(self, why: str) -> None:
        if self._connected:
            self._connected = False
            log.warning("lost the Slamware robot at %s (%s); reconnecting every %d ms",
                        self.url, why, round(self._reconn_wait * 1000))
            if self._lost is not None:
                self._lost.set()

    # --- requests ----------------------------------------------------------------------------

    async def _request(self, method: str, path: str, *, timeout: float | None = None,
                       params: dict[str, Any] | None = None, json: Any = None,
                       data: bytes | None = None) -> Reply:
        if not self._connected:
            raise NotConnectedError(f"the robot at {self.url} is not connected")
        try:
            reply = await self._http.request(method, path, timeout=timeout or self._timeout,
                                             params=params, json=json, data=data)
        except TransportError as exc:
            silent = time.monotonic() - self._last_ok
            if not exc.timed_out or silent > 2.0 * self._timeout:
                self._lose(f"{method} {path}: {exc}")
            if not self._connected:
                raise NotConnectedError(f"{method} {path}: {exc}") from None
            raise BackendError(f"{method} {path}: {exc}") from None
        self._last_ok = time.monotonic()
        return reply

    @staticmethod
    def _failed(method: str, path: str, reply: Reply) -> BackendError:
        text = reply.text()
        return BackendError(f"{method} {path}: HTTP {reply.status}" + (f": {text}" if text else ""))

    async def _json(self, method: str, path: str, *, missing_ok: bool = False,
                    timeout: float | None = None, params: dict[str, Any] | None = None,
                    json: Any = None) -> Any:
        """The JSON answer; ``None`` for a 404 when ``missing_ok``."""
        reply = await self._request(method, path, timeout=timeout, params=params, json=json)
        if reply.status == 404 and missing_ok:
            return None
        if not reply.ok:
            raise self._failed(method, path, reply)
        try:
            return reply.json()
        except ValueError:
            raise BackendError(f"{method} {path}: not JSON: {reply.text()}") from None

    async def _get(self, path: str, convert: Callable[[Any], T], *,
                   missing_ok: bool = False, timeout: float | None = None) -> T | None:
        value = await self._json("GET", path, missing_ok=missing_ok, timeout=timeout)
        if value is None and missing_ok:
            return None
        return self._convert(path, convert, value)

    @staticmethod
    def _convert(path: str, convert: Callable[[Any], T], value: Any) -> T:
        try:
            return convert(value)
        except (ValueError, TypeError, KeyError) as exc:
            raise BackendError(f"{path}: unexpected answer: {exc}") from None

    async def _command(self, method: str, path: str, json: Any = None, *,
                       data: bytes | None = None, timeout: float | None = None) -> bool | None:
        """A setter: HTTP errors raise; a bare ``false`` raises; ``true`` or no body pass.
        Returns the boolean answer (``None`` without one)."""
        reply = await self._request(method, path, json=json, data=data,
                                    timeout=timeout or self._control_timeout)
        if not reply.ok:
            raise self._failed(method, path, reply)
        answer = self._answer(reply)
        if answer is False:
            raise BackendError(f"{method} {path}: the robot answered false")
        return answer

    @staticmethod
    def _answer(reply: Reply) -> bool | None:
        """A setter's bare boolean; anything else (no body, an object) reads as ``None``."""
        try:
            value = reply.json()
        except ValueError:
            return None
        return value if isinstance(value, bool) else None

    async def _bool(self, path: str) -> bool:
        return bool(await self._get(path, lambda v: shapes.boolean(v, path)))

    @staticmethod
    def _explore_only(kind: MapKind) -> None:
        if kind != MapKind.EXPLORERMAP:
            raise UnsupportedError(f"the REST API only serves the explore map, not {kind!r}")

    # --- state -------------------------------------------------------------------------------

    async def get_pose(self) -> Pose2D:
        return await self._get(paths.POSE, shapes.pose_from)

    async def get_odopose(self) -> Pose2D:
        """The odometry (dead-reckoning) pose; not part of :class:`RobotBackend`."""
        return await self._get(paths.ODOPOSE, shapes.pose_from)

    async def get_odometry(self) -> Odometry:
        stamp = time.time()
        pose, twist = await asyncio.gather(self.get_pose(),
                                           self._get(paths.SPEED, shapes.speed_from))
        return Odometry(pose, twist, stamp)

    async def get_laser_scan(self) -> LaserScan:
        stamp = time.time()  # like the ROS node: the time the request started
        return await self._get(paths.LASERSCAN, lambda v: shapes.laser_scan_from(v, stamp))

    async def get_known_area(self, kind: MapKind = MapKind.EXPLORERMAP) -> Rect:
        self._explore_only(kind)
        return await self._get(paths.KNOWN_AREA, shapes.rect_from)

    async def get_map(
        self, area: Rect | None = None, kind: MapKind = MapKind.EXPLORERMAP
    ) -> MapRegion:
        self._explore_only(kind)
        params = None
        if area is not None:
            params = {"min_x": repr(float(area.x)), "min_y": repr(float(area.y)),
                      "max_x": repr(float(area.x + area.width)),
                      "max_y": repr(float(area.y + area.height))}
        reply = await self._request("GET", paths.EXPLORE_MAP, params=params,
                                    timeout=self._bulk_timeout)
        region = None
        if reply.status != 404:  # some robots answer 404 while they have no map
            if not reply.ok:
                raise self._failed("GET", paths.EXPLORE_MAP, reply)
            try:
                region = mapformat.decode(reply.body)
            except mapformat.MapFormatError as exc:
                raise BackendError(f"GET {paths.EXPLORE_MAP}: {exc}") from None
        if region is None:  # no map yet
            x, y = (area.x, area.y) if area is not None else (0.0, 0.0)
            region = MapRegion(x, y, mapformat.DEFAULT_RESOLUTION,
                               np.zeros((0, 0), dtype=np.uint8))
        return region

    async def clear_map(self, kind: MapKind = MapKind.EXPLORERMAP) -> None:
        self._explore_only(kind)
        await self._command("DELETE", paths.MAPS)

    async def get_map_update(self, kind: MapKind = MapKind.EXPLORERMAP) -> bool:
        self._explore_only(kind)
        return await self._bool(paths.MAPPING_ENABLE)

    async def set_map_update(self, enabled: bool, kind: MapKind = MapKind.EXPLORERMAP) -> None:
        self._explore_only(kind)
        await self._command("PUT", paths.MAPPING_ENABLE, {"enable": bool(enabled)})

    async def get_localization_enabled(self) -> bool:
        return await self._bool(paths.LOCALIZATION_ENABLE)

    async def set_localization_enabled(self, enabled: bool) -> None:
        await self._command("PUT", paths.LOCALIZATION_ENABLE, {"enable": bool(enabled)})

    async def get_localization_quality(self) -> int:
        return await self._get(paths.QUALITY,
                               lambda v: round(shapes.number(v, "localization quality")))

    async def set_pose(self, pose: Pose2D) -> None:
        _finite_pose(pose)
        await self._command("PUT", paths.POSE, shapes.pose3d_json(pose))

    async def install_map(self, explore: MapRegion | None, walls: Sequence[Line],
                          tracks: Sequence[Line], home: Pose2D | None, pose: Pose2D) -> None:
        """PUT as our composite-map container (what sim-device takes; SLAMTEC's ``.stcm`` is
        proprietary and cannot be written here), then set the pose."""
        await self.set_composite_map(composite_map.encode(composite_map.CompositeMap(
            explore, tuple(walls), tuple(tracks), home)), pose)

    async def recover_localization(
        self,
        area: Rect | None = None,
        max_time_ms: int | None = None,
        movement: LocalizationMovement | None = None,
    ) -> ActionInfo:
        if max_time_ms is not None and max_time_ms <= 0:
            raise BackendError("max_time_ms must be positive")
        return await self._start_action(shapes.recover_request(area, max_time_ms, movement))

    async def get_power_status(self) -> PowerStatus:
        return await self._get(paths.POWER_STATUS, shapes.power_from)

    async def get_board_temperature(self) -> int:
        """Not in the REST API: 0 (the node publishes it in ``RobotBasicState``)."""
        self._require_connection()
        return 0

    async def get_sensors_info(self) -> list[BasicSensorInfo]:
        """Not in the REST API: no basic sensors."""
        self._require_connection()
        return []

    async def get_sensor_values(self) -> dict[int, BasicSensorValue]:
        self._require_connection()
        return {}

    def _require_connection(self) -> None:
        if not self._connected:
            raise NotConnectedError(f"the robot at {self.url} is not connected")

    async def get_device_info(self) -> DeviceInfo:
        sdk = f"hitrobot-server {__version__} (REST)"
        return await self._get(paths.ROBOT_INFO, lambda v: shapes.device_info_from(v, sdk))

    async def get_health(self) -> HealthInfo:
        return await self._get(paths.ROBOT_HEALTH, shapes.health_from)

    async def clear_health_error(self, error_code: int) -> bool:
        path = f"{paths.ROBOT_HEALTH}/{int(error_code)}"
        reply = await self._request("DELETE", path, timeout=self._control_timeout)
        if reply.status in (400, 404):  # "Invalid Error Code": not active
            return False
        if not reply.ok:
            raise self._failed("DELETE", path, reply)
        return self._answer(reply) is not False

    # --- power -------------------------------------------------------------------------------

    async def power_off(self) -> None:
        """``POST power/:shutdown`` with both intervals 0 (shut down now; what a restart
        interval of 0 means is not documented), then treat the robot as gone."""
        await self._command("POST", paths.POWER_SHUTDOWN,
                            {"shutdown_time_interval": 0, "restart_time_interval": 0})
        self._lose("shutting down on request")

    async def reboot(self) -> None:
        """``POST power/:restartmodule`` (``RestartModeSoft``: the Slamware software restarts),
        then treat the robot as gone; the connection task picks it up when it is back."""
        await self._command("POST", paths.POWER_RESTART_MODULE, {"mode": "RestartModeSoft"})
        self._lose("restarting on request")

    # --- motion ------------------------------------------------------------------------------

    async def _start_action(self, body: dict) -> ActionInfo:
        name = body["action_name"].removeprefix(shapes.ACTION_PREFIX)
        reply = await self._request("POST", paths.ACTIONS, json=body,
                                    timeout=self._control_timeout)
        if not reply.ok:
            text = reply.text()
            raise BackendError(f"the robot could not start {name} (HTTP {reply.status}"
                               + (f": {text})" if text else ")"))
        try:
            return shapes.action_from(reply.json())
        except ValueError as exc:
            raise BackendError(f"POST {paths.ACTIONS} ({name}): unexpected answer: {exc}") \
                from None

    async def move_to(
        self,
        targets: Sequence[Point2D],
        options: MoveOptions | None = None,
        yaw: float = 0.0,
    ) -> ActionInfo:
        options = options or MoveOptions()
        targets = list(targets)
        if not targets:
            raise BackendError("move_to needs at least one target")
        for t in targets:
            if not (math.isfinite(t.x) and math.isfinite(t.y)):
                raise BackendError("move_to targets must be finite")
        dropped = options.flags & shapes.DROPPED_FLAGS
        if dropped:
            log.debug("move flags %s have no REST form; not sent", dropped)
        if options.flags & MoveOptionFlag.RETURN_UNREACHABLE_DIRECTLY:
            await self._check_targets(targets)
        if options.flags & MoveOptionFlag.APPENDING:
            current = await self.get_current_action()
            if current is not None and current.action_name in MOVE_ACTIONS:
                targets = [*await self.get_remaining_milestones(), *targets]
        info = await self._start_action(shapes.move_to_request(targets, options, yaw))
        self._moves[info.action_id] = (targets[-1], arrival_tolerance(options))
        while len(self._moves) > ACTION_HISTORY:
            self._moves.pop(next(iter(self._moves)))
        return info

    async def compute_path(
        self, start: Pose2D | None, goal: Pose2D, options: MoveOptions | None = None
    ) -> list[Point2D]:
        """REST has no planning without moving, but the server has the robot's map: it plans
        itself with the simulator's planner (:func:`~..sim.navigation.path_search`) on a
        costmap of the robot's explore map, virtual walls and tracks and the blocked areas
        we sent (the robot's own planner and footprint may differ)."""
        options = options or MoveOptions()
        for value in (goal.x, goal.y) + (() if start is None else (start.x, start.y)):
            if not math.isfinite(value):
                raise BackendError("compute_path needs finite poses")
        origin = await self.get_pose() if start is None else start
        costmap = await self._costmap()
        search = path_search(costmap, (origin.x, origin.y), (goal.x, goal.y), options)
        result = await run_in_slices(search, self._require_connection)
        if not result.ok:
            raise BackendError(f"no path: {result.reason}")
        return [Point2D(x, y) for x, y in result.path]

    async def _costmap(self, area: Rect | None = None) -> Costmap:
        """The planner's view of the robot's map (the known area when ``area`` is None)."""
        region = await self.get_map(area)
        if region.cells.size == 0:
            raise BackendError("the robot has no map to plan on")
        spec = GridSpec(region.origin_x, region.origin_y, region.resolution,
                        region.width, region.height)
        return build_costmap(
            spec, region.cells >= 128, region.cells == 0, CostmapConfig(),
            walls=await self.get_lines(ArtifactUsage.VIRTUAL_WALL),
            blocked=self._blocked,
            tracks=await self.get_lines(ArtifactUsage.VIRTUAL_TRACK))

    async def _check_targets(self, targets: Sequence[Point2D]) -> None:
        """``RETURN_UNREACHABLE_DIRECTLY`` has no REST form: refuse here a target the robot
        cannot stand on (lethal on our costmap of its map), as the flag asks."""
        for t in targets:
            costmap = await self._costmap(Rect(t.x - 1.0, t.y - 1.0, 2.0, 2.0))
            if costmap.lethal_at(np.array([[t.x, t.y]])).any():
                raise BackendError(f"target ({t.x:.2f}, {t.y:.2f}) is occupied or unreachable "
                                   "(RETURN_UNREACHABLE_DIRECTLY)")

    async def move_by_direction(
        self,
        direction: ActionDirection,
        options: MoveOptions | None = None,
        duration: float = 0.5,
    ) -> ActionInfo:
        _positive_duration(duration)
        try:
            direction = ActionDirection(direction)
        except ValueError:
            raise BackendError(f"unknown direction {direction!r}") from None
        return await self._start_action(
            shapes.move_by_request(direction, None, duration, options))

    async def move_by_theta(
        self, theta: float, options: MoveOptions | None = None, duration: float = 0.5
    ) -> ActionInfo:
        _positive_duration(duration)
        if not math.isfinite(theta):
            raise BackendError("theta must be finite")
        return await self._start_action(shapes.move_by_request(None, theta, duration, options))

    async def rotate_to(self, yaw: float, options: MoveOptions | None = None) -> ActionInfo:
        if not math.isfinite(yaw):
            raise BackendError("yaw must be finite")
        return await self._start_action(shapes.rotate_request(yaw, True, options))

    async def rotate(self, angle: float, options: MoveOptions | None = None) -> ActionInfo:
        if not math.isfinite(angle):
            raise BackendError("angle must be finite")
        return await self._start_action(shapes.rotate_request(angle, False, options))

    async def go_home(self, options: MoveOptions | None = None) -> ActionInfo:
        return await self._start_action(shapes.go_home_request(options))

    async def cancel_action(self) -> ActionInfo | None:
        current = await self.get_current_action()
        if current is None:
            return None
        reply = await self._request("DELETE", paths.CURRENT_ACTION,
                                    timeout=self._control_timeout)
        if not reply.ok and reply.status != 404:  # 404: it finished meanwhile
            raise self._failed("DELETE", paths.CURRENT_ACTION, reply)
        after = await self.get_action(current.action_id)
        if after is None:
            return current
        # a finished action reads back as a gravestone: keep the name and stage we know
        return dataclasses.replace(after, action_name=after.action_name or current.action_name,
                                   stage=after.stage or current.stage)

    async def get_current_action(self) -> ActionInfo | None:
        action = await self._get(paths.CURRENT_ACTION, shapes.action_from, missing_ok=True)
        return None if action is None or action.done else action

    async def get_action(self, action_id: int) -> ActionInfo | None:
        """The action; a move we started that the robot calls a success but that ended
        farther from its target than the tolerance (plus :data:`ARRIVAL_SLACK`) reads as
        FAILED with the distance, so no interface reports an arrival that did not happen."""
        action = await self._get(f"{paths.ACTIONS}/{int(action_id)}", shapes.action_from,
                                 missing_ok=True)
        move = self._moves.get(int(action_id))
        if action is None or move is None or not action.succeeded:
            return action
        if isinstance(move, ActionInfo):  # judged when it finished
            return move
        target, tolerance = move
        pose = await self.get_pose()
        off = math.hypot(pose.x - target.x, pose.y - target.y)
        if off > tolerance + ARRIVAL_SLACK:
            action = dataclasses.replace(action, result=ActionResult.FAILED, reason=(
                f"target unreachable: the robot stopped {off:.2f} m from ({target.x:.2f}, "
                f"{target.y:.2f}) (tolerance {tolerance:.2f} m)"))
        self._moves[int(action_id)] = action
        return action

    async def get_remaining_path(self) -> list[Point2D]:
        return await self._get(paths.PATH, shapes.path_from, missing_ok=True) or []

    async def get_remaining_milestones(self) -> list[Point2D]:
        return await self._get(paths.MILESTONES, shapes.path_from, missing_ok=True) or []

    async def set_velocity(self, linear: float, angular: float) -> None:
        """REST has no velocity control. Emulated with short ``MoveByAction`` actions (held
        :data:`MANUAL_HOLD` s, re-sent when the command changes or half the hold passed):

        * the magnitude becomes the move's ``speed_ratio`` against the nominal manual speeds
          :data:`MANUAL_LINEAR` / :data:`MANUAL_ANGULAR` (clamped to 0.1-1, the REST range);
        * turning in place → ``TURNLEFT`` / ``TURNRIGHT``; driving forward while turning → a
          ``theta`` heading of ``angular / 2`` rad (the robot steers towards it), forward
          only → ``FORWARD``; backward → ``BACKWARD`` (REST cannot reverse along a curve, the
          turn is dropped);
        * a zero twist cancels the manual move at once, so the robot coasts at most the rest of
          one short hold after the last command."""
        if not (math.isfinite(linear) and math.isfinite(angular)):
            raise BackendError("velocities must be finite")
        loop = asyncio.get_running_loop()
        drive, turn = abs(linear) / MANUAL_LINEAR, abs(angular) / MANUAL_ANGULAR
        if drive < 2e-3 and turn < 2e-3:
            manual, self._manual = self._manual, None
            if manual is not None:
                current = await self.get_current_action()
                if current is not None and current.action_id == manual[0]:
                    await self._request("DELETE", paths.CURRENT_ACTION,
                                        timeout=self._control_timeout)
            return
        direction: ActionDirection | None = None
        theta: float | None = None
        if drive < 2e-3 or (turn > 4 * drive):
            direction = ActionDirection.TURNLEFT if angular > 0 else ActionDirection.TURNRIGHT
            ratio = turn
        elif linear < 0:
            direction, ratio = ActionDirection.BACKWARD, drive
        elif turn < 2e-3:
            direction, ratio = ActionDirection.FORWARD, drive
        else:
            theta = max(-1.2, min(1.2, angular / 2.0))
            ratio = drive / math.cos(theta)
        ratio = round(min(1.0, max(0.1, ratio)), 2)
        command = (direction if direction is not None else round(theta or 0.0, 2), ratio)
        now = loop.time()
        manual = self._manual
        if manual is not None and manual[1] == command and now - manual[2] < MANUAL_HOLD / 2:
            return
        info = await self._start_action(shapes.move_by_request(
            direction, theta, MANUAL_HOLD, MoveOptions(speed_ratio=ratio)))
        self._manual = (info.action_id, command, now)

    # --- artifacts ---------------------------------------------------------------------------

    async def get_lines(self, usage: ArtifactUsage) -> list[Line]:
        path = paths.lines(usage)
        lines = await self._get(path, shapes.lines_from, missing_ok=True)
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
        await self._command("POST", path, [shapes.line_json(ln) for ln in lines])
        fresh = [ln for ln in await self.get_lines(usage) if ln.id not in before]
        stored = []
        for wanted in lines:
            match = next((ln for ln in fresh if _same_segment(ln, wanted)), None)
            if match is not None:
                fresh.remove(match)
                stored.append(match)
        return stored + fresh if len(stored) < len(lines) else stored

    async def remove_line(self, usage: ArtifactUsage, line_id: int) -> bool:
        path = f"{paths.lines(usage)}/{int(line_id)}"
        reply = await self._request("DELETE", path, timeout=self._control_timeout)
        if reply.status == 404:
            return False
        if not reply.ok:
            raise self._failed("DELETE", path, reply)
        return self._answer(reply) is not False

    async def clear_lines(self, usage: ArtifactUsage) -> None:
        await self._command("DELETE", paths.lines(usage))

    async def move_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        path = paths.lines(usage)
        reply = await self._request("PUT", path, json=[shapes.line_json(ln) for ln in lines],
                                    timeout=self._control_timeout)
        if reply.status == 404:
            return False
        if not reply.ok:
            raise self._failed("PUT", path, reply)
        return self._answer(reply) is not False

    async def set_blocked_areas(self, areas: Sequence[Sequence[Point2D]]) -> None:
        """Replace our forbidden rectangle areas with a cover of ``areas``.

        REST has no polygons; each one becomes rectangle areas of usage ``forbidden_area``
        (:func:`shapes.cover_polygon`: one for a rectangle, strips of 5 cm otherwise), tagged
        with :data:`shapes.BLOCKED_METADATA`. Areas without that tag (made by other tools) are
        left alone; ours from an earlier run are replaced."""
        path = f"{paths.RECTANGLE_AREAS}/{paths.FORBIDDEN_AREA}"
        covers = [shapes.cover_polygon(list(polygon)) for polygon in areas]
        self._blocked = tuple(tuple(polygon) for polygon in areas)
        async with self._blocked_lock:
            existing = await self._json("GET", path, missing_ok=True)
            if existing is None:
                raise UnsupportedError("the robot has no rectangle areas (firmware older than "
                                       "the REST API 1.1?): blocked areas cannot be sent")
            ours = self._convert(path, shapes.owned_area_ids, existing)
            for area_id in ours:
                await self._command("DELETE", f"{path}/{area_id}")
            for cover in covers:
                for start, end, half_width in cover:
                    await self._command("POST", path, shapes.rectangle_area_json(
                        start, end, half_width, shapes.BLOCKED_METADATA))

    async def get_home_pose(self) -> Pose2D | None:
        return await self._get(paths.HOMEPOSE, shapes.pose_from, missing_ok=True)

    async def set_home_pose(self, pose: Pose2D) -> None:
        _finite_pose(pose)
        await self._command("PUT", paths.HOMEPOSE, shapes.pose3d_json(pose))

    async def get_composite_map(self) -> bytes:
        reply = await self._request("GET", paths.STCM, timeout=self._bulk_timeout)
        if not reply.ok:
            raise self._failed("GET", paths.STCM, reply)
        return reply.body

    async def check_composite_map(self, data: bytes) -> None:
        """Our own container (what the simulator and sim-device serve) is checked completely;
        SLAMTEC's ``.stcm`` is proprietary and only the robot can judge it (its ``PUT`` refuses
        a bad file without touching the map)."""
        self._require_connection()
        if data[:len(composite_map.MAGIC)] == composite_map.MAGIC:
            try:
                composite_map.decode(data)
            except composite_map.CompositeMapError as exc:
                raise BackendError(f"invalid composite map: {exc}") from None
        elif not data:
            raise BackendError("the composite map is empty")

    async def set_composite_map(self, data: bytes, pose: Pose2D) -> None:
        """PUT the file unchanged (the robot then sits at the origin), then set the pose."""
        _finite_pose(pose)
        await self._command("PUT", paths.STCM, data=bytes(data), timeout=self._bulk_timeout)
        await self._command("PUT", paths.POSE, shapes.pose3d_json(pose))


def _finite_pose(pose: Pose2D) -> None:
    if not all(math.isfinite(v) for v in (pose.x, pose.y, pose.yaw)):
        raise BackendError("pose must be finite")


def _positive_duration(duration: float) -> None:
    if not (math.isfinite(duration) and duration > 0.0):
        raise BackendError("duration must be positive")


def _same_segment(a: Line, b: Line, tol: float = 1e-3) -> bool:
    return (math.hypot(a.start.x - b.start.x, a.start.y - b.start.y) < tol
            and math.hypot(a.end.x - b.end.x, a.end.y - b.end.y) < tol)

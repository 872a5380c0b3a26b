"""``SimBackend``: the simulator behind the async :class:`RobotBackend` interface.

A background task steps the :class:`Simulator` at a fixed rate, paced against the event loop's
clock (``time_scale`` > 1 runs faster than real time). Every request is answered synchronously
from simulator state, so awaiting a method never waits on the stepping task. Work inside one
step is bounded (planning and relocalization run in slices), typically a few milliseconds; the
slowest step seen is kept in :attr:`SimBackend.max_step_seconds` for diagnostics.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from collections.abc import Callable, Sequence
from typing import TypeVar

from .. import composite_map
from ..backend import BackendError, NotConnectedError, RobotBackend, UnsupportedError
from ..model import (
    ActionDirection,
    ActionInfo,
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
    MoveOptions,
    Odometry,
    Point2D,
    Pose2D,
    PowerStatus,
    Rect,
)
from .navigation import path_search
from .persist import SimMemory
from .planner import run_in_slices
from .simulator import Simulator

log = logging.getLogger(__name__)

T = TypeVar("T")

SLOW_STEP = 0.05
"""A step slower than this (s) is logged: it delays every other task on the loop."""
MAX_CATCH_UP = 5
"""Steps run back to back at most when the loop fell behind; older backlog is dropped."""
SAMPLE_EVERY = 0.25
"""Wall-clock seconds between samples of the pose, battery and map for the state store."""


class SimBackend(RobotBackend):
    """Runs a :class:`Simulator` on the event loop."""

    def __init__(self, simulator: Simulator, rate_hz: float = 20.0, time_scale: float = 1.0,
                 memory: SimMemory | None = None):
        if rate_hz <= 0.0 or time_scale <= 0.0:
            raise ValueError("rate_hz and time_scale must be positive")
        self.simulator = simulator
        self.memory = memory
        """Where the robot's map, lines, pose and battery survive a restart (None: nowhere)."""
        self.restored = memory.restore(simulator) if memory is not None else []
        self._sampled = -math.inf
        self._period = 1.0 / rate_hz
        self._time_scale = time_scale
        self._task: asyncio.Task[None] | None = None
        self._reboot: asyncio.Task[None] | None = None
        self.max_step_seconds = 0.0
        self.reboot_delay = 2.0
        """Wall-clock seconds a simulated reboot keeps the robot offline."""

    @property
    def connected(self) -> bool:
        return self._task is not None and not self._task.done()

    async def start(self) -> None:
        if not self.connected:
            self._task = asyncio.get_running_loop().create_task(self._run(), name="sim-stepper")

    async def stop(self) -> None:
        reboot, self._reboot = self._reboot, None
        if reboot is not None and reboot is not asyncio.current_task():
            reboot.cancel()
        task, self._task = self._task, None
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            if self.memory is not None:  # the last pose and map (the store flushes on close)
                self.memory.sync(self.simulator, asyncio.get_running_loop().time(), urgent=True)

    async def power_off(self) -> None:
        """The simulated robot goes offline and stays so (until the server restarts)."""
        if not self.connected:
            raise NotConnectedError("simulator is not running")
        await self.stop()

    async def reboot(self) -> None:
        """Offline now; back after :attr:`reboot_delay` as a freshly started simulator (same
        world, seed and configuration, no actions) with what the robot keeps: its map, lines,
        home and pose from the state folder (as at start-up when there is none)."""
        if not self.connected:
            raise NotConnectedError("simulator is not running")
        await self.stop()

        async def come_back() -> None:
            await asyncio.sleep(self.reboot_delay)
            self.simulator = self.simulator.restarted()
            if self.memory is not None:  # a robot keeps its map, lines and pose on reboot
                self.memory.restore(self.simulator)
            self._reboot = None
            await self.start()

        self._reboot = asyncio.get_running_loop().create_task(come_back(), name="sim-reboot")

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        due = loop.time()
        while True:
            behind = 0
            while loop.time() >= due and behind < MAX_CATCH_UP:
                try:
                    self._step()
                except Exception:
                    log.exception("simulator step failed; the simulated robot is now offline")
                    raise
                due += self._period
                behind += 1
            now = loop.time()
            if self.memory is not None and now - self._sampled >= SAMPLE_EVERY:
                self._sampled = now
                self.memory.sync(self.simulator, now)
            if now >= due:
                due = now + self._period
            await asyncio.sleep(due - now if due > now else 0.0)

    def _step(self) -> None:
        started = time.perf_counter()
        self.simulator.step(self._period * self._time_scale)
        spent = time.perf_counter() - started
        if spent > self.max_step_seconds:
            self.max_step_seconds = spent
        if spent > SLOW_STEP:
            log.warning("simulator step took %.1f ms", spent * 1000.0)

    def _call(self, fn: Callable[..., T], *args: object) -> T:
        """Run a simulator call as a backend request: refuse when stopped, translate errors."""
        if not self.connected:
            raise NotConnectedError("simulator is not running")
        try:
            return fn(*args)
        except ValueError as exc:
            raise BackendError(str(exc)) from exc

    def _map_call(self, kind: MapKind, fn: Callable[..., T], *args: object) -> T:
        _explore_only(kind)
        return self._call(fn, *args)

    async def _change(self, fn: Callable[..., T], *args: object) -> T:
        """A request that changes what the robot remembers: answered once it is on disk."""
        result = self._call(fn, *args)
        if self.memory is not None:
            pending = self.memory.sync(self.simulator, asyncio.get_running_loop().time(),
                                       urgent=True)
            if pending is not None:
                try:
                    await pending
                except OSError as exc:
                    raise BackendError(f"done, but not saved to the state folder: {exc}") \
                        from None
        return result

    # --- state -------------------------------------------------------------------------------

    async def get_pose(self) -> Pose2D:
        return self._call(lambda: self.simulator.pose)

    async def get_odometry(self) -> Odometry:
        return self._call(self.simulator.odometry)

    async def get_laser_scan(self) -> LaserScan:
        return self._call(lambda: self.simulator.latest_scan)

    async def get_known_area(self, kind: MapKind = MapKind.EXPLORERMAP) -> Rect:
        return self._map_call(kind, self.simulator.known_area)

    async def get_map(
        self, area: Rect | None = None, kind: MapKind = MapKind.EXPLORERMAP
    ) -> MapRegion:
        return self._map_call(kind, self.simulator.map_region, area)

    async def clear_map(self, kind: MapKind = MapKind.EXPLORERMAP) -> None:
        _explore_only(kind)
        await self._change(self.simulator.clear_map)

    async def get_map_update(self, kind: MapKind = MapKind.EXPLORERMAP) -> bool:
        return self._map_call(kind, lambda: self.simulator.map_update)

    async def set_map_update(self, enabled: bool, kind: MapKind = MapKind.EXPLORERMAP) -> None:
        _explore_only(kind)
        await self._change(setattr, self.simulator, "map_update", enabled)

    async def get_localization_enabled(self) -> bool:
        return self._call(lambda: self.simulator.localization_enabled)

    async def set_localization_enabled(self, enabled: bool) -> None:
        await self._change(setattr, self.simulator, "localization_enabled", enabled)

    async def get_localization_quality(self) -> int:
        return self._call(lambda: self.simulator.localization_quality)

    async def set_pose(self, pose: Pose2D) -> None:
        await self._change(self.simulator.set_pose, pose)

    async def recover_localization(
        self,
        area: Rect | None = None,
        max_time_ms: int | None = None,
        movement: LocalizationMovement | None = None,
    ) -> ActionInfo:
        return self._call(self.simulator.recover_localization, area, max_time_ms, movement)

    async def get_power_status(self) -> PowerStatus:
        return self._call(self.simulator.power_status)

    async def get_board_temperature(self) -> int:
        return self._call(self.simulator.board_temperature)

    async def get_sensors_info(self) -> list[BasicSensorInfo]:
        return self._call(self.simulator.sensors_info)

    async def get_sensor_values(self) -> dict[int, BasicSensorValue]:
        return self._call(self.simulator.sensor_values)

    async def get_device_info(self) -> DeviceInfo:
        return self._call(self.simulator.device_info)

    async def get_health(self) -> HealthInfo:
        return self._call(self.simulator.health)

    async def clear_health_error(self, error_code: int) -> bool:
        return self._call(self.simulator.clear_health_error, error_code)

    # --- motion ------------------------------------------------------------------------------

    async def move_to(
        self,
        targets: Sequence[Point2D],
        options: MoveOptions | None = None,
        yaw: float = 0.0,
    ) -> ActionInfo:
        return self._call(self.simulator.move_to, targets, options, yaw)

    async def compute_path(
        self, start: Pose2D | None, goal: Pose2D, options: MoveOptions | None = None
    ) -> list[Point2D]:
        """A* on the current planning costmap with ``move_to``'s options, run in slices of
        :data:`~.planner.PLAN_SLICE` expansions so a long search never stalls the loop."""
        options = options or MoveOptions()
        for value in (goal.x, goal.y) + (() if start is None else (start.x, start.y)):
            if not math.isfinite(value):
                raise BackendError("compute_path needs finite poses")
        sim = self._call(lambda: self.simulator)
        origin = sim.pose if start is None else start
        search = path_search(sim.costmap(), (origin.x, origin.y), (goal.x, goal.y), options)

        def alive() -> None:
            if not self.connected:
                raise NotConnectedError("simulator is not running")

        result = await run_in_slices(search, alive)
        if not result.ok:
            raise BackendError(f"no path: {result.reason}")
        return [Point2D(x, y) for x, y in result.path]

    async def move_by_direction(
        self,
        direction: ActionDirection,
        options: MoveOptions | None = None,
        duration: float = 0.5,
    ) -> ActionInfo:
        return self._call(self.simulator.move_by_direction, direction, options, duration)

    async def move_by_theta(
        self, theta: float, options: MoveOptions | None = None, duration: float = 0.5
    ) -> ActionInfo:
        return self._call(self.simulator.move_by_theta, theta, options, duration)

    async def rotate_to(self, yaw: float, options: MoveOptions | None = None) -> ActionInfo:
        return self._call(self.simulator.rotate_to, yaw, options)

    async def rotate(self, angle: float, options: MoveOptions | None = None) -> ActionInfo:
        return self._call(self.simulator.rotate, angle, options)

    async def go_home(self, options: MoveOptions | None = None) -> ActionInfo:
        return self._call(self.simulator.go_home, options)

    async def cancel_action(self) -> ActionInfo | None:
        return self._call(self.simulator.cancel_action)

    async def get_current_action(self) -> ActionInfo | None:
        return self._call(self.simulator.current_action)

    async def get_action(self, action_id: int) -> ActionInfo | None:
        return self._call(self.simulator.action, action_id)

    async def get_remaining_path(self) -> list[Point2D]:
        return self._call(self.simulator.remaining_path)

    async def get_remaining_milestones(self) -> list[Point2D]:
        return self._call(self.simulator.remaining_milestones)

    async def set_velocity(self, linear: float, angular: float) -> None:
        self._call(self.simulator.set_velocity, linear, angular)

    # --- artifacts ---------------------------------------------------------------------------

    async def get_lines(self, usage: ArtifactUsage) -> list[Line]:
        return self._call(self.simulator.get_lines, usage)

    async def add_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> list[Line]:
        return await self._change(self.simulator.add_lines, usage, lines)

    async def remove_line(self, usage: ArtifactUsage, line_id: int) -> bool:
        return await self._change(self.simulator.remove_line, usage, line_id)

    async def clear_lines(self, usage: ArtifactUsage) -> None:
        await self._change(self.simulator.clear_lines, usage)

    async def move_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        return await self._change(self.simulator.move_lines, usage, lines)

    async def set_blocked_areas(self, areas: Sequence[Sequence[Point2D]]) -> None:
        self._call(self.simulator.set_blocked_areas, areas)

    async def get_home_pose(self) -> Pose2D | None:
        return self._call(lambda: self.simulator.home_pose)

    async def set_home_pose(self, pose: Pose2D) -> None:
        await self._change(setattr, self.simulator, "home_pose", pose)

    async def get_composite_map(self) -> bytes:
        return self._call(self.simulator.composite_map)

    async def check_composite_map(self, data: bytes) -> None:
        self._call(self.simulator.check_composite_map, data)

    async def set_composite_map(self, data: bytes, pose: Pose2D) -> None:
        await self._change(self.simulator.load_composite_map, data, pose)

    async def install_map(self, explore: MapRegion | None, walls: Sequence[Line],
                          tracks: Sequence[Line], home: Pose2D | None, pose: Pose2D) -> None:
        """Through the simulator's own container, so the content is checked completely, as a
        loaded file is, before anything changes."""
        await self.set_composite_map(composite_map.encode(composite_map.CompositeMap(
            explore, tuple(walls), tuple(tracks), home)), pose)


def _explore_only(kind: MapKind) -> None:
    if kind != MapKind.EXPLORERMAP:
        raise UnsupportedError(f"the simulator only has an explore map, not {kind!r}")

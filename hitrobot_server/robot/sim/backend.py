"""``SimBackend``: the simulator behind the async :class:`RobotBackend` interface.

:class:`~.runner.SimRunner` steps the :class:`Simulator` on the event loop. Every request is
answered synchronously from simulator state, so awaiting a method never waits on the stepping
task.
"""

from __future__ import annotations

import asyncio
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
from ..planning.search import check_poses, searched_path
from .persist import SimMemory
from .runner import SimRunner
from .simulator import Simulator

T = TypeVar("T")


class SimBackend(RobotBackend):
    """Answers a :class:`Simulator`'s requests; :attr:`runner` steps it on the event loop."""

    def __init__(self, simulator: Simulator, rate_hz: float = 20.0, time_scale: float = 1.0,
                 memory: SimMemory | None = None):
        if rate_hz <= 0.0 or time_scale <= 0.0:
            raise ValueError("rate_hz and time_scale must be positive")
        self.memory = memory
        """Where the robot's map, lines, pose and battery survive a restart (None: nowhere)."""
        self.restored = memory.restore(simulator) if memory is not None else []
        self.runner = SimRunner(simulator, rate_hz, time_scale, memory)

    @property
    def simulator(self) -> Simulator:
        """The simulator now running (a reboot replaces it)."""
        return self.runner.simulator

    @property
    def max_step_seconds(self) -> float:
        """The slowest step so far (s)."""
        return self.runner.max_step_seconds

    @property
    def reboot_delay(self) -> float:
        """Wall-clock seconds a simulated reboot keeps the robot offline."""
        return self.runner.reboot_delay

    @reboot_delay.setter
    def reboot_delay(self, seconds: float) -> None:
        self.runner.reboot_delay = seconds

    @property
    def connected(self) -> bool:
        return self.runner.running

    async def start(self) -> None:
        await self.runner.start()

    async def stop(self) -> None:
        await self.runner.stop()

    async def power_off(self) -> None:
        await self.runner.power_off()

    async def reboot(self) -> None:
        await self.runner.reboot()

    def _alive(self) -> None:
        if not self.connected:
            raise NotConnectedError("simulator is not running")

    def _call(self, fn: Callable[..., T], *args: object) -> T:
        """Run a simulator call as a backend request: refuse when stopped, translate errors."""
        self._alive()
        try:
            return fn(*args)
        except ValueError as exc:
            raise BackendError(str(exc)) from exc

    def _map_call(self, kind: MapKind, fn: Callable[..., T], *args: object) -> T:
        _explore_only(kind)
        return self._call(fn, *args)

    async def _change(self, fn: Callable[..., T], *args: object) -> T:
        """A request that changes what the robot remembers: answered once it is on disk."""
        lines = None if self.memory is None else self.simulator.saved_lines()
        result = self._call(fn, *args)
        if self.memory is not None:
            pending = self.memory.sync(self.simulator, asyncio.get_running_loop().time(),
                                       urgent=True)
            if pending is not None:
                try:
                    await pending
                except OSError as exc:
                    undone = self.memory.take_back_lines(self.simulator, lines)
                    raise BackendError(f"{exc}" + ("; the walls, tracks and home were taken "
                                                   "back" if undone else "")) from None
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
        check_poses(start, goal)
        sim = self._call(lambda: self.simulator)
        origin = sim.pose if start is None else start
        return await searched_path(sim.costmap(), origin, goal, options, self._alive)

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

    # --- the simulator's own controls (no real robot has them) ------------------------------
    def set_battery(self, percent: float) -> float:
        return self._call(self.simulator.set_battery, percent)

    def kidnap(self, true_pose: Pose2D) -> None:
        self._call(self.simulator.kidnap, true_pose)

    def emergency_stop(self, pressed: bool) -> None:
        self._call(self.simulator.emergency_stop, pressed)

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

"""``ComposedBackend``: one :class:`RobotBackend` made of one adapter per capability.

A backend whose capabilities are separate objects (the Slamware REST client: one adapter per
protocol over a shared connection) hands them here; every :class:`RobotBackend` method is
forwarded, written out, to the adapter of its capability. Nodes get the adapters themselves
(:func:`~hitrobot_server.robot.factory.robot_of`), so the forwarding serves the callers that
hold the whole backend (the server's start and stop, tools and tests).
"""

from __future__ import annotations

from collections.abc import Sequence

from .backend import (
    Link,
    LocalizationBackend,
    MapBackend,
    MotionBackend,
    PowerBackend,
    RobotBackend,
    SensorBackend,
)
from .model import (
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

EXPLORE = MapKind.EXPLORERMAP


class ComposedBackend(RobotBackend):
    """Every capability of one robot, each served by its own adapter."""

    def __init__(self, link: Link, motion: MotionBackend, localization: LocalizationBackend,
                 maps: MapBackend, sensors: SensorBackend, power: PowerBackend) -> None:
        self.link = link
        self.motion = motion
        self.localization = localization
        self.maps = maps
        self.sensors = sensors
        self.power = power

    # --- Link --------------------------------------------------------------------------------

    @property
    def connected(self) -> bool:
        return self.link.connected

    async def start(self) -> None:
        await self.link.start()

    async def stop(self) -> None:
        await self.link.stop()

    # --- MotionBackend -----------------------------------------------------------------------

    async def move_to(self, targets: Sequence[Point2D], options: MoveOptions | None = None,
                      yaw: float = 0.0) -> ActionInfo:
        return await self.motion.move_to(targets, options, yaw)

    async def compute_path(self, start: Pose2D | None, goal: Pose2D,
                           options: MoveOptions | None = None) -> list[Point2D]:
        return await self.motion.compute_path(start, goal, options)

    async def move_by_direction(self, direction: ActionDirection,
                                options: MoveOptions | None = None,
                                duration: float = 0.5) -> ActionInfo:
        return await self.motion.move_by_direction(direction, options, duration)

    async def move_by_theta(self, theta: float, options: MoveOptions | None = None,
                            duration: float = 0.5) -> ActionInfo:
        return await self.motion.move_by_theta(theta, options, duration)

    async def rotate_to(self, yaw: float, options: MoveOptions | None = None) -> ActionInfo:
        return await self.motion.rotate_to(yaw, options)

    async def rotate(self, angle: float, options: MoveOptions | None = None) -> ActionInfo:
        return await self.motion.rotate(angle, options)

    async def go_home(self, options: MoveOptions | None = None) -> ActionInfo:
        return await self.motion.go_home(options)

    async def cancel_action(self) -> ActionInfo | None:
        return await self.motion.cancel_action()

    async def get_current_action(self) -> ActionInfo | None:
        return await self.motion.get_current_action()

    async def get_action(self, action_id: int) -> ActionInfo | None:
        return await self.motion.get_action(action_id)

    async def get_remaining_path(self) -> list[Point2D]:
        return await self.motion.get_remaining_path()

    async def get_remaining_milestones(self) -> list[Point2D]:
        return await self.motion.get_remaining_milestones()

    async def set_velocity(self, linear: float, angular: float) -> None:
        await self.motion.set_velocity(linear, angular)

    # --- LocalizationBackend -----------------------------------------------------------------

    async def get_pose(self) -> Pose2D:
        return await self.localization.get_pose()

    async def set_pose(self, pose: Pose2D) -> None:
        await self.localization.set_pose(pose)

    async def get_localization_enabled(self) -> bool:
        return await self.localization.get_localization_enabled()

    async def set_localization_enabled(self, enabled: bool) -> None:
        await self.localization.set_localization_enabled(enabled)

    async def get_localization_quality(self) -> int:
        return await self.localization.get_localization_quality()

    async def recover_localization(self, area: Rect | None = None,
                                   max_time_ms: int | None = None,
                                   movement: LocalizationMovement | None = None) -> ActionInfo:
        return await self.localization.recover_localization(area, max_time_ms, movement)

    # --- MapBackend --------------------------------------------------------------------------

    async def get_known_area(self, kind: MapKind = EXPLORE) -> Rect:
        return await self.maps.get_known_area(kind)

    async def get_map(self, area: Rect | None = None, kind: MapKind = EXPLORE) -> MapRegion:
        return await self.maps.get_map(area, kind)

    async def clear_map(self, kind: MapKind = EXPLORE) -> None:
        await self.maps.clear_map(kind)

    async def get_map_update(self, kind: MapKind = EXPLORE) -> bool:
        return await self.maps.get_map_update(kind)

    async def set_map_update(self, enabled: bool, kind: MapKind = EXPLORE) -> None:
        await self.maps.set_map_update(enabled, kind)

    async def get_lines(self, usage: ArtifactUsage) -> list[Line]:
        return await self.maps.get_lines(usage)

    async def add_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> list[Line]:
        return await self.maps.add_lines(usage, lines)

    async def remove_line(self, usage: ArtifactUsage, line_id: int) -> bool:
        return await self.maps.remove_line(usage, line_id)

    async def clear_lines(self, usage: ArtifactUsage) -> None:
        await self.maps.clear_lines(usage)

    async def move_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        return await self.maps.move_lines(usage, lines)

    async def set_blocked_areas(self, areas: Sequence[Sequence[Point2D]]) -> None:
        await self.maps.set_blocked_areas(areas)

    async def get_home_pose(self) -> Pose2D | None:
        return await self.maps.get_home_pose()

    async def set_home_pose(self, pose: Pose2D) -> None:
        await self.maps.set_home_pose(pose)

    async def get_composite_map(self) -> bytes:
        return await self.maps.get_composite_map()

    async def check_composite_map(self, data: bytes) -> None:
        await self.maps.check_composite_map(data)

    async def set_composite_map(self, data: bytes, pose: Pose2D) -> None:
        await self.maps.set_composite_map(data, pose)

    async def install_map(self, explore: MapRegion | None, walls: Sequence[Line],
                          tracks: Sequence[Line], home: Pose2D | None, pose: Pose2D) -> None:
        await self.maps.install_map(explore, walls, tracks, home, pose)

    # --- SensorBackend -----------------------------------------------------------------------

    async def get_odometry(self) -> Odometry:
        return await self.sensors.get_odometry()

    async def get_laser_scan(self) -> LaserScan:
        return await self.sensors.get_laser_scan()

    async def get_sensors_info(self) -> list[BasicSensorInfo]:
        return await self.sensors.get_sensors_info()

    async def get_sensor_values(self) -> dict[int, BasicSensorValue]:
        return await self.sensors.get_sensor_values()

    async def get_device_info(self) -> DeviceInfo:
        return await self.sensors.get_device_info()

    async def get_health(self) -> HealthInfo:
        return await self.sensors.get_health()

    async def clear_health_error(self, error_code: int) -> bool:
        return await self.sensors.clear_health_error(error_code)

    # --- PowerBackend ------------------------------------------------------------------------

    async def get_power_status(self) -> PowerStatus:
        return await self.power.get_power_status()

    async def get_board_temperature(self) -> int:
        return await self.power.get_board_temperature()

    async def power_off(self) -> None:
        await self.power.power_off()

    async def reboot(self) -> None:
        await self.power.reboot()

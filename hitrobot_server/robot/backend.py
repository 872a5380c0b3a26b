"""The robot boundary: the capabilities a node can ask of one robot.

Nodes never talk to a robot directly; they await the methods of the capabilities they were
handed. The boundary is shaped after the Slamware REST API (actions with status/result/reason
polled by id, lines by usage, bare getters and setters), so a REST client maps each method to
one or two HTTP calls, while the simulator answers from memory.

It is split by concern into small protocols, so a node names just what it uses:
:class:`Link` (reachable? connect, disconnect), :class:`MotionBackend` (actions and velocity),
:class:`LocalizationBackend` (where the robot believes it is), :class:`MapBackend` (map, lines,
home, blocked areas, whole-map transfer), :class:`SensorBackend` (odometry, lidar, bumpers,
identity, health) and :class:`PowerBackend` (battery, shutdown, reboot). A backend implements
each with an adapter of its own, composed by
:class:`~hitrobot_server.robot.composed.ComposedBackend`: the Slamware REST client
(``rest/``: link, motion, localization, maps, sensors, power over one ``RestLink``) and the
simulator (``sim/backend/``: the same six over its ``SimRunner``). Nodes, tools and tests get
them one by one, bundled in a :class:`~hitrobot_server.robot.capabilities.Robot` (with the
motion behind the locomotion gate, ``locomotion.py`` ``GatedMotion``). A new capability is its
protocol here plus one adapter per backend (plus its place in ``GatedMotion`` for a motion
method); nothing is forwarded, so nothing else changes until a node calls it.

Conventions: methods are cheap to await and never block the loop; poses are in the robot's
map frame; failures raise :class:`BackendError`;
``NotConnectedError`` means the robot is unreachable (the node should drop the request and
retry later, as ``slamware_ros_sdk_server_node`` does).
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Sequence
from typing import Protocol

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

ACTION_PREFIX = "slamtec.agent.actions."
"""Action names carry the REST prefix so clients written against Slamware can match on them."""


class BackendError(Exception):
    """A request the robot refused or could not carry out."""


class NotConnectedError(BackendError):
    """The robot is not reachable (not started, or the connection dropped)."""


class UnsupportedError(BackendError):
    """The robot does not offer this feature (e.g. a map kind other than the explore map)."""


class Link(Protocol):
    """The connection to one robot: whether it is reachable, connecting and disconnecting."""

    @property
    @abstractmethod
    def connected(self) -> bool:
        """Whether the robot is reachable right now."""

    @property
    def trouble(self) -> str:
        """Why the robot's answers cannot be used although it is reachable (errors, nonsense,
        answers over their bound); "" while they can."""
        return ""

    @abstractmethod
    async def start(self) -> None:
        """Connect (or start simulating); idempotent."""

    @abstractmethod
    async def stop(self) -> None:
        """Disconnect (or stop simulating); idempotent."""


class MotionBackend(Protocol):
    """Starting, following and stopping robot actions, and velocity control."""

    @abstractmethod
    async def move_to(
        self,
        targets: Sequence[Point2D],
        options: MoveOptions | None = None,
        yaw: float = 0.0,
    ) -> ActionInfo:
        """Navigate through ``targets`` in order. ``yaw`` is the final heading and only counts
        with ``WITH_YAW``; ``APPENDING`` adds the targets to a running move instead of
        replacing it."""

    async def compute_path(
        self, start: Pose2D | None, goal: Pose2D, options: MoveOptions | None = None
    ) -> list[Point2D]:
        """Plan a path from ``start`` (the robot's pose when ``None``) to ``goal`` without
        moving, with the planner ``move_to`` would use and the same ``options`` (virtual-track
        mode, ``NO_SMOOTH``, ``RETURN_UNREACHABLE_DIRECTLY``, ``planning_area``). The path runs
        from the start to the goal (or the free spot that replaces an unusable goal). Raises
        :class:`BackendError` with the reason when there is no path. Optional; raises
        :class:`UnsupportedError` when the robot cannot plan without moving."""
        raise UnsupportedError("this robot cannot plan a path without moving")

    @abstractmethod
    async def move_by_direction(
        self,
        direction: ActionDirection,
        options: MoveOptions | None = None,
        duration: float = 0.5,
    ) -> ActionInfo:
        """Drive or turn for ``duration`` seconds without obstacle avoidance (re-send to keep
        moving, as with the REST ``MoveByAction``)."""

    @abstractmethod
    async def move_by_theta(
        self, theta: float, options: MoveOptions | None = None, duration: float = 0.5
    ) -> ActionInfo:
        """Like :meth:`move_by_direction`, heading ``theta`` radians off the robot's nose."""

    @abstractmethod
    async def rotate_to(self, yaw: float, options: MoveOptions | None = None) -> ActionInfo:
        """Turn in place to the absolute heading ``yaw``."""

    @abstractmethod
    async def rotate(self, angle: float, options: MoveOptions | None = None) -> ActionInfo:
        """Turn in place by ``angle`` radians (positive = counter-clockwise)."""

    @abstractmethod
    async def go_home(self, options: MoveOptions | None = None) -> ActionInfo:
        """Return to the home dock and dock for charging."""

    @abstractmethod
    async def cancel_action(self) -> ActionInfo | None:
        """Cancel the current action; its final state, or ``None`` when idle."""

    @abstractmethod
    async def get_current_action(self) -> ActionInfo | None:
        """The unfinished current action, or ``None`` when idle (REST 404)."""

    @abstractmethod
    async def get_action(self, action_id: int) -> ActionInfo | None:
        """A recent action by id (the last 20 are kept), or ``None``."""

    @abstractmethod
    async def get_remaining_path(self) -> list[Point2D]:
        """The planned path still ahead of the robot; empty when idle."""

    @abstractmethod
    async def get_remaining_milestones(self) -> list[Point2D]:
        """The targets of the current move still to reach."""

    @abstractmethod
    async def set_velocity(self, linear: float, angular: float) -> None:
        """Drive at ``linear`` m/s and ``angular`` rad/s (``/cmd_vel``). The command holds until
        the next one or until the backend's dead-man timeout lapses, then the robot stops. It
        replaces any running action."""


class LocalizationBackend(Protocol):
    """Where the robot believes it is on its map, and how sure it is."""

    @abstractmethod
    async def get_pose(self) -> Pose2D:
        """The localized robot pose (what the robot believes, not ground truth)."""

    @abstractmethod
    async def set_pose(self, pose: Pose2D) -> None:
        """Force the robot's believed pose."""

    @abstractmethod
    async def get_localization_enabled(self) -> bool:
        """Whether the robot localizes against its map (off = pure odometry)."""

    @abstractmethod
    async def set_localization_enabled(self, enabled: bool) -> None:
        """Switch localization on or off."""

    @abstractmethod
    async def get_localization_quality(self) -> int:
        """Localization quality 0-100; 0 while localization is disabled."""

    @abstractmethod
    async def recover_localization(
        self,
        area: Rect | None = None,
        max_time_ms: int | None = None,
        movement: LocalizationMovement | None = None,
    ) -> ActionInfo:
        """Start a relocalization action searching ``area`` (whole map when ``None``/empty)."""


class MapBackend(Protocol):
    """The robot's map: cells, mapping switch, virtual lines, blocked areas, home, whole-map
    transfer."""

    @abstractmethod
    async def get_known_area(self, kind: MapKind = MapKind.EXPLORERMAP) -> Rect:
        """Bounding box of the mapped area; empty when nothing is mapped."""

    @abstractmethod
    async def get_map(
        self, area: Rect | None = None, kind: MapKind = MapKind.EXPLORERMAP
    ) -> MapRegion:
        """The map cells covering ``area`` (the known area when ``None``), cell-aligned."""

    @abstractmethod
    async def clear_map(self, kind: MapKind = MapKind.EXPLORERMAP) -> None:
        """Forget the map."""

    @abstractmethod
    async def get_map_update(self, kind: MapKind = MapKind.EXPLORERMAP) -> bool:
        """Whether scans are written into the map (mapping mode)."""

    @abstractmethod
    async def set_map_update(self, enabled: bool, kind: MapKind = MapKind.EXPLORERMAP) -> None:
        """Switch mapping on or off; off freezes the map."""

    @abstractmethod
    async def get_lines(self, usage: ArtifactUsage) -> list[Line]:
        """All virtual walls or all virtual tracks."""

    @abstractmethod
    async def add_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> list[Line]:
        """Store lines and return them with the ids they were stored under (a non-zero unused
        id is kept; otherwise the robot assigns one)."""

    @abstractmethod
    async def remove_line(self, usage: ArtifactUsage, line_id: int) -> bool:
        """Delete one line; False if no such id."""

    @abstractmethod
    async def clear_lines(self, usage: ArtifactUsage) -> None:
        """Delete every line of ``usage``."""

    @abstractmethod
    async def move_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        """Replace the geometry of existing lines by id; False if any id is unknown (the known
        ones are still moved)."""

    @abstractmethod
    async def set_blocked_areas(self, areas: Sequence[Sequence[Point2D]]) -> None:
        """Areas the planner must keep out of (the map manager's blocked masks; a REST client
        maps them to forbidden rectangle areas)."""

    @abstractmethod
    async def get_home_pose(self) -> Pose2D | None:
        """Pose of the home dock, or ``None`` when the map has no dock (REST 404)."""

    @abstractmethod
    async def set_home_pose(self, pose: Pose2D) -> None:
        """Declare where the home dock is."""

    @abstractmethod
    async def get_composite_map(self) -> bytes:
        """The robot's whole map as bytes (``sync_get_stcm``). A real robot returns its own
        format; the simulator returns :mod:`hitrobot_server.robot.composite_map` bytes."""

    async def check_composite_map(self, data: bytes) -> None:  # noqa: B027 - optional hook
        """Raise :class:`BackendError` when :meth:`set_composite_map` would refuse ``data``;
        callers check before anything destructive. By default nothing can be checked locally
        (the robot judges its own format when it gets it)."""

    @abstractmethod
    async def set_composite_map(self, data: bytes, pose: Pose2D) -> None:
        """Replace map, lines and home with ``data`` and set the robot's pose
        (``sync_set_stcm``)."""

    @abstractmethod
    async def install_map(self, explore: MapRegion | None, walls: Sequence[Line],
                          tracks: Sequence[Line], home: Pose2D | None, pose: Pose2D) -> None:
        """Replace the explore map (cleared when ``None``), the virtual walls and tracks and
        the home dock with these, and set the robot's pose: a map loaded from disk or drawn by
        a client. Each backend writes them in its own form (the caller knows no map format)."""


class SensorBackend(Protocol):
    """What the robot senses and reports about itself: odometry, lidar, bumpers, health."""

    @abstractmethod
    async def get_odometry(self) -> Odometry:
        """Pose plus body-frame velocity."""

    @abstractmethod
    async def get_laser_scan(self) -> LaserScan:
        """The latest lidar frame with the pose it was taken from."""

    @abstractmethod
    async def get_sensors_info(self) -> list[BasicSensorInfo]:
        """The bumpers, cliff sensors and sonars the robot has."""

    @abstractmethod
    async def get_sensor_values(self) -> dict[int, BasicSensorValue]:
        """Current readings keyed by sensor id. ``is_in_impact`` follows slamware_ros_sdk: a
        digital sensor is in impact when triggered; a sonar always reports in impact."""

    @abstractmethod
    async def get_device_info(self) -> DeviceInfo:
        """Identity and version strings."""

    @abstractmethod
    async def get_health(self) -> HealthInfo:
        """Active warnings and errors."""

    @abstractmethod
    async def clear_health_error(self, error_code: int) -> bool:
        """Acknowledge an error by its ``error_code``; False if it was not active."""


class PowerBackend(Protocol):
    """Battery and board state, shutdown and reboot."""

    @abstractmethod
    async def get_power_status(self) -> PowerStatus:
        """Battery, charging and dock state."""

    @abstractmethod
    async def get_board_temperature(self) -> int:
        """Main board temperature in degrees Celsius."""

    async def power_off(self) -> None:
        """Shut the robot down: it goes offline and stays so (``/cmd_string shutdown``).
        Optional; raises :class:`UnsupportedError` when the robot cannot do it."""
        raise UnsupportedError("this robot cannot be shut down remotely")

    async def reboot(self) -> None:
        """Restart the robot: it goes offline now and comes back later with a fresh state
        (``/cmd_string reboot``); returns once it is offline. Optional; raises
        :class:`UnsupportedError` when the robot cannot do it."""
        raise UnsupportedError("this robot cannot be rebooted remotely")

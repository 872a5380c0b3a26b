"""The simulated robot: physics, sensors and the robot's own software, stepped in sim time.

``Simulator(world, seed)`` owns everything; :meth:`Simulator.step` advances it. Time advances in
fixed ticks (``SimConfig.tick``, 40 Hz by default); ``step(dt)`` runs as many whole ticks as
``dt`` covers and carries the remainder, so a run depends only on the seed and the sequence of
commands, not on how the caller slices time. Each tick: the current action computes a velocity
command from the *believed* pose, the chassis moves in the *true* world (refusing collisions and
firing a bumper), odometry drift and the battery are updated. Every ``scan_period`` the lidar
measures from the true pose, localization re-estimates its quality, and (every ``map_period``,
when enabled) the explore map integrates the scan at the believed pose.

The public methods mirror :class:`~hitrobot_server.robot.backend.RobotBackend` synchronously;
bad arguments raise ``ValueError``.
"""

from __future__ import annotations

import hashlib
import math
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ... import __version__
from .. import composite_map
from ..model import (
    ActionDirection,
    ActionInfo,
    ActionResult,
    ArtifactUsage,
    BasicSensorInfo,
    BasicSensorValue,
    DeviceInfo,
    HealthComponent,
    HealthError,
    HealthInfo,
    HealthLevel,
    LaserScan,
    Line,
    LocalizationMovement,
    MapRegion,
    MoveOptionFlag,
    MoveOptions,
    Odometry,
    Point2D,
    Pose2D,
    PowerStatus,
    Rect,
    Twist2D,
    health_error_code,
)
from .actions import (
    Action,
    GoHomeAction,
    MoveByAction,
    MoveToAction,
    RecoverLocalizationAction,
    RotateAction,
    VelocityControlAction,
)
from .artifacts import LineStore
from .costmap import Costmap, CostmapConfig, build_costmap
from .geometry import compose, inverse, wrap_angle
from .grid import distance_field
from .kinematics import DiffDrive, DriveLimits
from .lidar import Lidar, LidarConfig, RayCaster
from .localization import (
    LikelihoodField,
    LocalizationConfig,
    Localizer,
    RelocalizationSearch,
    scan_points,
)
from .mapping import ExploreMapper
from .power import Battery, PowerConfig, on_dock
from .sensors import SensorSuite
from .world import World

ACTION_HISTORY = 20
"""Finished actions stay queryable by id for this many actions, as on the REST API."""
LOW_QUALITY = 30
"""Localization quality below which health reports an error."""
TRUE_FIELD_CELLS = 20
"""Reach (cells) of the ground-truth distance field used for collisions and matching."""

POWER_LOW = health_error_code(HealthLevel.WARN, HealthComponent.POWER, 0x0100)
LOCALIZATION_LOW = health_error_code(HealthLevel.ERROR, HealthComponent.SYSTEM, 0x0900)
RELOCALIZATION_FAILED = health_error_code(HealthLevel.ERROR, HealthComponent.SYSTEM, 0x0800)


@dataclass(frozen=True, slots=True)
class SimConfig:
    """Rates, budgets and sub-configurations of a :class:`Simulator`."""

    tick: float = 0.025
    scan_period: float = 0.1
    map_period: float = 0.2
    velocity_timeout: float = 0.5
    plan_budget: int = 2000
    match_budget: int = 400_000
    initial_battery: float = 80.0
    prebuilt_map: bool = True
    map_update: bool = False
    drive: DriveLimits = field(default_factory=DriveLimits)
    lidar: LidarConfig = field(default_factory=LidarConfig)
    costmap: CostmapConfig = field(default_factory=CostmapConfig)
    localization: LocalizationConfig = field(default_factory=LocalizationConfig)
    power: PowerConfig = field(default_factory=PowerConfig)


class Simulator:
    """One simulated robot in one world. Not thread-safe; drive it from one thread/loop."""

    def __init__(self, world: World, seed: int = 0, config: SimConfig | None = None,
                 start: Pose2D | None = None,
                 others: Callable[[Simulator], Sequence[Pose2D]] | None = None) -> None:
        cfg = config or SimConfig()
        self.world = world
        self.start = start or world.start_pose
        self._others = others
        """The true poses of the other robots in a shared world (they see and bump into each
        other; see :mod:`~hitrobot_server.robot.sim.shared`)."""
        self.config = cfg
        self.seed = seed
        self._rng = np.random.default_rng(seed)
        spec = world.spec
        res = spec.resolution
        true_cells = distance_field(world.solid, TRUE_FIELD_CELLS)
        self._true_field = true_cells
        self._caster = RayCaster(spec, world.solid)
        self._lidar = Lidar(self._caster, cfg.lidar, self._rng)
        self._sensors = SensorSuite(self._caster, cfg.drive.radius)
        self._drive = DiffDrive(self.start, cfg.drive, self._clearance)
        self._mapper = ExploreMapper(spec)
        if cfg.prebuilt_map:
            self._mapper.seed(world.occupied, world.free)
        self._mapper.enabled = cfg.map_update
        clearance = np.where(world.occupied, 0.0, true_cells * res)
        self._field = LikelihoodField(spec, clearance, cfg.localization)
        stand = cfg.drive.radius + 0.5 * res + cfg.costmap.safety_margin
        self._standable = true_cells * res >= stand
        self._localizer = Localizer(self._field, cfg.localization, self._rng)
        self._battery = Battery(cfg.initial_battery, cfg.power)
        self._lines = LineStore()
        self._blocked: tuple[tuple[Point2D, ...], ...] = ()
        self._blocked_revision = 0
        self._home = world.dock_pose
        self._costmap: Costmap | None = None
        self._costmap_key: tuple[int, int, int] | None = None
        self._with_robots: tuple[tuple, Costmap] | None = None  # the costmap with the others
        self._current: Action | None = None
        self._history: OrderedDict[int, Action] = OrderedDict()
        self._next_action_id = 1
        self._health: dict[int, HealthError] = {}
        self._next_health_id = 1
        self._relocalization_failed = False
        self._ticks = 0
        self._pending = 0.0
        self._scan_every = max(1, round(cfg.scan_period / cfg.tick))
        self._map_every = max(1, round(cfg.map_period / cfg.tick))
        self._scan: LaserScan
        self._sense()

    # --- time --------------------------------------------------------------------------------

    @property
    def time(self) -> float:
        return self._ticks * self.config.tick

    def step(self, dt: float) -> None:
        """Advance by ``dt`` seconds of simulated time (whole ticks; the rest carries over)."""
        if not dt >= 0.0:
            raise ValueError("dt must be non-negative")
        tick = self.config.tick
        self._pending += dt
        while self._pending >= tick - 1e-9:
            self._pending -= tick
            self._tick()

    def _tick(self) -> None:
        tick = self.config.tick
        action = self._current
        linear, angular = (0.0, 0.0)
        if action is not None and not action.done:
            linear, angular = action.tick(self)
        before = self._drive.pose
        contact = self._drive.step(linear, angular, tick)
        self._ticks += 1
        if contact is not None:
            self._sensors.bump(contact, self.time)
            if action is not None and not action.done:
                action.on_collision(contact)
        after = self._drive.pose
        self._localizer.on_motion(
            after,
            math.hypot(after.x - before.x, after.y - before.y),
            wrap_angle(after.yaw - before.yaw),
        )
        lim = self.config.drive
        effort = max(
            abs(self._drive.linear) / lim.max_linear, abs(self._drive.angular) / lim.max_angular
        )
        self._battery.step(tick, effort, self.docked)
        if self._ticks % self._scan_every == 0:
            self._sense()

    def _sense(self) -> None:
        true_pose = self._drive.pose
        ranges = self._lidar.measure(true_pose)
        others = self.others()
        if others:
            ranges = np.minimum(ranges, discs_along_rays(
                true_pose, self._lidar.angles, others, self.config.drive.radius,
                self.config.lidar.max_range))
        ranges.flags.writeable = False  # handed out in LaserScan; shared by every reader
        believed = self._localizer.believed(true_pose)
        angles = self._lidar.angles
        self._scan = LaserScan(believed, angles, ranges, self.time)
        self._scan_odometry = true_pose
        self._sensors.update_sonars(true_pose)
        points = scan_points(angles, ranges, self.config.localization.match_points)
        self._localizer.update(self.config.scan_period, true_pose, points)
        if self._ticks % self._map_every == 0:
            self._mapper.integrate(believed, angles, ranges)

    def _clearance(self, x: float, y: float) -> float:
        """Distance (m) from a point to the nearest solid cell edge of the true world."""
        spec = self.world.spec
        ix, iy = spec.cell(x, y)
        if not spec.contains(ix, iy):
            return 0.0
        clearance = (float(self._true_field[iy, ix]) - 0.5) * spec.resolution
        for other in self.others():  # another robot's disc is an obstacle too
            clearance = min(clearance, math.hypot(x - other.x, y - other.y) - self.drive.radius)
        return clearance

    def others(self) -> Sequence[Pose2D]:
        """The true poses of the other robots sharing this world (none when alone)."""
        return self._others(self) if self._others is not None else ()

    def restarted(self) -> Simulator:
        """A fresh simulator in its start-up state (a reboot): same world, seed, configuration,
        start pose and neighbours."""
        return Simulator(self.world, seed=self.seed, config=self.config, start=self.start,
                         others=self._others)

    # --- what actions see (ActionContext) ----------------------------------------------------

    @property
    def pose(self) -> Pose2D:
        """The believed pose (what the robot reports)."""
        return self._localizer.believed(self._drive.pose)

    @property
    def true_pose(self) -> Pose2D:
        """Ground truth (what the lidar sees from); for tests and debugging only."""
        return self._drive.pose

    @property
    def drive(self) -> DriveLimits:
        return self.config.drive

    @property
    def plan_budget(self) -> int:
        return self.config.plan_budget

    @property
    def match_budget(self) -> int:
        return self.config.match_budget

    @property
    def home_pose(self) -> Pose2D | None:
        return self._home

    @home_pose.setter
    def home_pose(self, pose: Pose2D) -> None:
        self._home = _checked_pose(pose)

    @property
    def docked(self) -> bool:
        return on_dock(self._drive.pose, self.world.dock_pose, self.config.power)

    @property
    def latest_scan(self) -> LaserScan:
        return self._scan

    def costmap(self) -> Costmap:
        """The planner's map; other robots in lidar range are obstacles in it (laid over the
        map's costmap again when one moved by a quarter metre)."""
        key = (self._mapper.revision, self._lines.revision, self._blocked_revision)
        if self._costmap is None or key != self._costmap_key:
            cells = self._mapper.cells()
            self._costmap = build_costmap(
                self.world.spec,
                cells >= 128,
                cells == 0,
                self.config.costmap,
                walls=self._lines.get(ArtifactUsage.VIRTUAL_WALL),
                blocked=self._blocked,
                tracks=self._lines.get(ArtifactUsage.VIRTUAL_TRACK),
            )
            self._costmap_key = key
            self._with_robots = None
        seen = tuple((round(p.x * 4) / 4, round(p.y * 4) / 4) for p in self._seen_robots())
        if not seen:
            return self._costmap
        if self._with_robots is None or self._with_robots[0] != seen:
            self._with_robots = (seen, with_robots(self._costmap, seen, self.config))
        return self._with_robots[1]

    def _seen_robots(self) -> list[Pose2D]:
        me = self._drive.pose
        reach = self.config.lidar.max_range
        return [p for p in self.others() if math.hypot(p.x - me.x, p.y - me.y) <= reach]

    def start_relocalization(self, area: Rect | None) -> RelocalizationSearch:
        scan = self._scan
        points = scan_points(scan.angles, scan.ranges, self.config.localization.match_points)
        return RelocalizationSearch(
            self._field, points, area, self._standable, self.config.localization
        )

    @property
    def scan_odometry(self) -> Pose2D:
        return self._scan_odometry

    def relocalize(self, match: Pose2D, at: Pose2D) -> None:
        """Believe ``match`` at odometry pose ``at``: the pose is the match plus the odometry
        motion since, whatever was believed (or forced with ``set_pose``) meanwhile."""
        now = self._drive.pose
        self._localizer.set_pose(compose(match, compose(inverse(at), now)), now)

    def report_relocalization(self, success: bool) -> None:
        self._relocalization_failed = not success

    # --- state queries -----------------------------------------------------------------------

    def odometry(self) -> Odometry:
        return Odometry(self.pose, Twist2D(self._drive.linear, 0.0, self._drive.angular), self.time)

    @property
    def map_update(self) -> bool:
        return self._mapper.enabled

    @map_update.setter
    def map_update(self, enabled: bool) -> None:
        self._mapper.enabled = bool(enabled)

    def known_area(self) -> Rect:
        return self._mapper.known_area()

    def map_region(self, area: Rect | None = None) -> MapRegion:
        return self._mapper.region(area)

    def clear_map(self) -> None:
        self._mapper.clear()

    @property
    def localization_enabled(self) -> bool:
        return self._localizer.enabled

    @localization_enabled.setter
    def localization_enabled(self, enabled: bool) -> None:
        self._localizer.enabled = bool(enabled)
        if not enabled:
            self._localizer.quality = 0

    @property
    def localization_quality(self) -> int:
        return self._localizer.quality

    def set_pose(self, pose: Pose2D) -> None:
        self._localizer.set_pose(_checked_pose(pose), self._drive.pose)

    def power_status(self) -> PowerStatus:
        return self._battery.status(self.docked)

    def board_temperature(self) -> int:
        return 38 + round(4.0 * abs(self._drive.linear) / self.config.drive.max_linear)

    def sensors_info(self) -> list[BasicSensorInfo]:
        return list(self._sensors.info)

    def sensor_values(self) -> dict[int, BasicSensorValue]:
        return self._sensors.values(self.time)

    def device_info(self) -> DeviceInfo:
        digest = hashlib.md5(f"hitrobot-sim-{self.seed}".encode(), usedforsecurity=False)
        return DeviceInfo(
            device_id=digest.hexdigest().upper(),
            model_id=0,
            model_name="hitrobot-sim",
            manufacturer_id=0,
            manufacturer_name="hitrobot",
            hardware_version="sim",
            software_version=__version__,
            sdp_version=__version__,
            sdk_version=__version__,
        )

    def health(self) -> HealthInfo:
        active = {
            POWER_LOW: (self._battery.low, HealthComponent.POWER, HealthLevel.WARN, "power low"),
            LOCALIZATION_LOW: (
                self._localizer.enabled and self._localizer.quality < LOW_QUALITY,
                HealthComponent.SYSTEM,
                HealthLevel.ERROR,
                "low localization quality",
            ),
            RELOCALIZATION_FAILED: (
                self._relocalization_failed,
                HealthComponent.SYSTEM,
                HealthLevel.ERROR,
                "relocalization failed",
            ),
        }
        for code, (on, component, level, message) in active.items():
            if on and code not in self._health:
                self._health[code] = HealthError(
                    self._next_health_id, component, level, code, message
                )
                self._next_health_id += 1
            elif not on:
                self._health.pop(code, None)
        return HealthInfo.from_errors(tuple(self._health.values()))

    def clear_health_error(self, error_code: int) -> bool:
        """Acknowledge an error; conditions that still hold are reported again."""
        if error_code == RELOCALIZATION_FAILED:
            self._relocalization_failed = False
        return self._health.pop(error_code, None) is not None

    # --- actions -----------------------------------------------------------------------------

    def move_to(
        self, targets: Sequence[Point2D], options: MoveOptions | None = None, yaw: float = 0.0
    ) -> ActionInfo:
        options = options or MoveOptions()
        if not targets:
            raise ValueError("move_to needs at least one target")
        for t in targets:
            _checked_point(t)
        if not math.isfinite(yaw):
            raise ValueError("yaw must be finite")
        current = self._current
        if (
            options.flags & MoveOptionFlag.APPENDING
            and isinstance(current, MoveToAction)
            and not current.done
        ):
            current.append(targets, options, yaw)
            return current.info()
        return self._start(MoveToAction(self._new_id(), targets, options, yaw))

    def move_by_direction(
        self, direction: ActionDirection, options: MoveOptions | None = None, duration: float = 0.5
    ) -> ActionInfo:
        direction = ActionDirection(direction)
        return self._start(
            MoveByAction(
                self._new_id(), options or MoveOptions(), _duration(duration), direction=direction
            )
        )

    def move_by_theta(
        self, theta: float, options: MoveOptions | None = None, duration: float = 0.5
    ) -> ActionInfo:
        if not math.isfinite(theta):
            raise ValueError("theta must be finite")
        return self._start(
            MoveByAction(self._new_id(), options or MoveOptions(), _duration(duration), theta=theta)
        )

    def rotate_to(self, yaw: float, options: MoveOptions | None = None) -> ActionInfo:
        if not math.isfinite(yaw):
            raise ValueError("yaw must be finite")
        return self._start(RotateAction(self._new_id(), yaw, options or MoveOptions(), True))

    def rotate(self, angle: float, options: MoveOptions | None = None) -> ActionInfo:
        if not math.isfinite(angle):
            raise ValueError("angle must be finite")
        return self._start(RotateAction(self._new_id(), angle, options or MoveOptions(), False))

    def go_home(self, options: MoveOptions | None = None) -> ActionInfo:
        return self._start(GoHomeAction(self._new_id(), options or MoveOptions()))

    def recover_localization(
        self,
        area: Rect | None = None,
        max_time_ms: int | None = None,
        movement: LocalizationMovement | None = None,
    ) -> ActionInfo:
        if max_time_ms is not None and max_time_ms <= 0:
            raise ValueError("max_time_ms must be positive")
        max_time = None if max_time_ms is None else max_time_ms / 1000.0
        movement = LocalizationMovement.NO_MOVE if movement is None else movement
        return self._start(RecoverLocalizationAction(self._new_id(), area, max_time, movement))

    def set_velocity(self, linear: float, angular: float) -> None:
        if not (math.isfinite(linear) and math.isfinite(angular)):
            raise ValueError("velocities must be finite")
        current = self._current
        if not isinstance(current, VelocityControlAction) or current.done:
            current = VelocityControlAction(self._new_id(), self.config.velocity_timeout)
            self._start(current)
        current.command(linear, angular, self.time)

    def cancel_action(self) -> ActionInfo | None:
        current = self._current
        if current is None or current.done:
            return None
        current.finish(ActionResult.ABORTED, "cancelled")
        return current.info()

    def current_action(self) -> ActionInfo | None:
        current = self._current
        return None if current is None or current.done else current.info()

    def action(self, action_id: int) -> ActionInfo | None:
        found = self._history.get(action_id)
        return None if found is None else found.info()

    def remaining_path(self) -> list[Point2D]:
        current = self._current
        return [] if current is None or current.done else current.remaining_path(self)

    def remaining_milestones(self) -> list[Point2D]:
        current = self._current
        return [] if current is None or current.done else current.milestones()

    def _new_id(self) -> int:
        action_id = self._next_action_id
        self._next_action_id += 1
        return action_id

    def _start(self, action: Action) -> ActionInfo:
        current = self._current
        if current is not None and not current.done:
            current.finish(ActionResult.ABORTED, "superseded by a new action")
        self._current = action
        self._history[action.action_id] = action
        while len(self._history) > ACTION_HISTORY:
            self._history.popitem(last=False)
        return action.info()

    # --- artifacts and maps ------------------------------------------------------------------

    def get_lines(self, usage: ArtifactUsage) -> list[Line]:
        return self._lines.get(ArtifactUsage(usage))

    def add_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> list[Line]:
        return self._lines.add(ArtifactUsage(usage), [_checked_line(line) for line in lines])

    def remove_line(self, usage: ArtifactUsage, line_id: int) -> bool:
        return self._lines.remove(ArtifactUsage(usage), line_id)

    def clear_lines(self, usage: ArtifactUsage) -> None:
        self._lines.clear(ArtifactUsage(usage))

    def move_lines(self, usage: ArtifactUsage, lines: Sequence[Line]) -> bool:
        return self._lines.move(ArtifactUsage(usage), [_checked_line(line) for line in lines])

    def set_blocked_areas(self, areas: Sequence[Sequence[Point2D]]) -> None:
        self._blocked = tuple(tuple(polygon) for polygon in areas)
        self._blocked_revision += 1

    def composite_map(self) -> bytes:
        """The map, lines and home as :mod:`~hitrobot_server.robot.composite_map` bytes."""
        known = self._mapper.known_area()
        cmap = composite_map.CompositeMap(
            explore=None if known.is_empty else self._mapper.region(known),
            walls=tuple(self._lines.get(ArtifactUsage.VIRTUAL_WALL)),
            tracks=tuple(self._lines.get(ArtifactUsage.VIRTUAL_TRACK)),
            home=self._home,
        )
        return composite_map.encode(cmap)

    def check_composite_map(self, data: bytes) -> composite_map.CompositeMap:
        """The decoded map if :meth:`load_composite_map` would take it; ``ValueError`` if
        not (checked completely, so loading cannot fail half-way)."""
        cmap = composite_map.decode(data)
        res = self.world.spec.resolution
        if cmap.explore is not None and abs(cmap.explore.resolution - res) > 1e-6:
            raise ValueError(f"map resolution {cmap.explore.resolution} differs from {res}")
        return cmap

    def load_composite_map(self, data: bytes, pose: Pose2D) -> None:
        """Install a composite map and set the believed pose; ``ValueError`` (and nothing
        changed) if either is invalid."""
        pose = _checked_pose(pose)
        cmap = self.check_composite_map(data)
        if cmap.explore is None:
            self._mapper.clear()
        else:
            self._mapper.load(cmap.explore)
        self._lines.replace_all(ArtifactUsage.VIRTUAL_WALL, cmap.walls)
        self._lines.replace_all(ArtifactUsage.VIRTUAL_TRACK, cmap.tracks)
        self._home = cmap.home
        self.set_pose(pose)

    # --- what survives a restart (see robot/sim/persist.py) -----------------------------------

    def saved_robot(self) -> dict:
        """The chassis as JSON: true and believed pose, battery, localization. (Mapping is a
        mode the robot starts without, as after a reboot.)"""
        t, b = self._drive.pose, self.pose
        return {"pose": [t.x, t.y, t.yaw], "believed": [b.x, b.y, b.yaw],
                "battery": round(self._battery.percentage, 2),
                "localization": self._localizer.enabled}

    def restore_robot(self, saved: dict) -> None:
        """Put the chassis back where :meth:`saved_robot` found it; ``ValueError`` (nothing
        changed) if ``saved`` is not such a record or the pose is not in free space."""
        try:
            pose = _checked_pose(Pose2D(*map(float, saved["pose"])))
            believed = _checked_pose(Pose2D(*map(float, saved["believed"])))
            battery = float(saved["battery"])
            localization = saved["localization"]
        except (KeyError, TypeError) as exc:
            raise ValueError(f"not a saved robot state ({exc})") from None
        if not (0.0 <= battery <= 100.0) or not isinstance(localization, bool):
            raise ValueError("battery or localization out of range")
        if self._clearance(pose.x, pose.y) < self.config.drive.radius * 0.5:
            raise ValueError(f"the saved pose ({pose.x:.2f}, {pose.y:.2f}) is inside an obstacle")
        self._drive.pose = pose
        self._drive.linear = self._drive.angular = 0.0
        self._localizer.set_pose(believed, pose)
        self.localization_enabled = localization
        self._battery.percentage = battery
        self._sense()

    def saved_lines(self) -> dict:
        """Virtual walls, tracks and the home pose as JSON."""
        def rows(usage: ArtifactUsage) -> list[list[float]]:
            return [[line.id, line.start.x, line.start.y, line.end.x, line.end.y]
                    for line in self._lines.get(usage)]

        home = self._home
        return {"walls": rows(ArtifactUsage.VIRTUAL_WALL),
                "tracks": rows(ArtifactUsage.VIRTUAL_TRACK),
                "home": None if home is None else [home.x, home.y, home.yaw]}

    def restore_lines(self, saved: dict) -> None:
        """Install what :meth:`saved_lines` gave; ``ValueError`` (nothing changed) if bad."""
        try:
            lines = {usage: [_checked_line(Line(int(i), Point2D(float(x0), float(y0)),
                                                Point2D(float(x1), float(y1))))
                             for i, x0, y0, x1, y1 in saved[key]]
                     for key, usage in (("walls", ArtifactUsage.VIRTUAL_WALL),
                                        ("tracks", ArtifactUsage.VIRTUAL_TRACK))}
            home = saved["home"]
            home = None if home is None else _checked_pose(Pose2D(*map(float, home)))
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"not saved lines ({exc})") from None
        for usage, items in lines.items():
            if len({line.id for line in items}) != len(items):
                raise ValueError("two lines share an id")
            self._lines.replace_all(usage, items)
        self._home = home

    @property
    def map_revision(self) -> int:
        return self._mapper.revision

    def saved_map(self) -> bytes:
        """The explore map alone, in our composite-map container."""
        known = self._mapper.known_area()
        return composite_map.encode(composite_map.CompositeMap(
            explore=None if known.is_empty else self._mapper.region(known),
            walls=(), tracks=(), home=None))

    def restore_map(self, data: bytes) -> None:
        """Install a map :meth:`saved_map` gave; ``ValueError`` (nothing changed) if bad."""
        cmap = self.check_composite_map(data)
        if cmap.explore is None:
            self._mapper.clear()
        else:
            self._mapper.load(cmap.explore)


def discs_along_rays(origin: Pose2D, angles: np.ndarray, centres: Sequence[Pose2D],
                     radius: float, max_range: float) -> np.ndarray:
    """Per beam (angles relative to ``origin``'s heading): the distance to the first disc of
    ``radius`` around any of ``centres``, or ``inf``."""
    world = np.asarray(angles) + origin.yaw
    ux, uy = np.cos(world), np.sin(world)
    out = np.full(world.shape, np.inf)
    for c in centres:
        cx, cy = c.x - origin.x, c.y - origin.y
        along = ux * cx + uy * cy
        miss2 = (cx * cx + cy * cy) - along * along
        inside = radius * radius - miss2
        t = along - np.sqrt(np.maximum(inside, 0.0))
        hit = (inside >= 0.0) & (t > 0.0) & (t <= max_range)
        out = np.where(hit, np.minimum(out, t), out)
    return out


def with_robots(base: Costmap, centres: Sequence[tuple[float, float]],
                config: SimConfig) -> Costmap:
    """``base`` with a robot's disc (as wide as this one) at each of ``centres``, inflated as
    :func:`build_costmap` inflates obstacles: lethal where the discs would touch (plus the
    safety margin), a decaying cost around, not parkable up to the park margin."""
    spec = base.spec
    c = config.costmap
    radius = config.drive.radius
    lethal_reach = 2 * radius + 0.5 * spec.resolution + c.safety_margin
    park_reach = lethal_reach + c.park_margin
    lethal, parkable, cost = base.lethal.copy(), base.parkable.copy(), base.cost.copy()
    span = math.ceil((radius + max(park_reach, c.inflation_radius)) / spec.resolution) + 1
    for x, y in centres:
        ix, iy = spec.cell(x, y)
        x0, x1 = max(ix - span, 0), min(ix + span + 1, spec.width)
        y0, y1 = max(iy - span, 0), min(iy + span + 1, spec.height)
        if x0 >= x1 or y0 >= y1:
            continue
        cx, cy = spec.center(np.arange(x0, x1)[None, :], np.arange(y0, y1)[:, None])
        d = np.hypot(cx - x, cy - y)
        lethal[y0:y1, x0:x1] |= d < lethal_reach
        parkable[y0:y1, x0:x1] &= d >= park_reach
        clearance = d - radius  # to the other disc's edge
        extra = 1.0 + c.inflation_cost * np.exp(-c.inflation_decay
                                                * np.maximum(clearance - radius, 0.0))
        extra = np.where(clearance < c.inflation_radius, extra, 1.0).astype(np.float32)
        np.maximum(cost[y0:y1, x0:x1], extra, out=cost[y0:y1, x0:x1])
    return Costmap(spec, lethal, cost, base.track, parkable)


def _checked_pose(pose: Pose2D) -> Pose2D:
    if not all(math.isfinite(v) for v in (pose.x, pose.y, pose.yaw)):
        raise ValueError("pose must be finite")
    return pose


def _checked_point(point: Point2D) -> Point2D:
    if not (math.isfinite(point.x) and math.isfinite(point.y)):
        raise ValueError("points must be finite")
    return point


def _checked_line(line: Line) -> Line:
    _checked_point(line.start)
    _checked_point(line.end)
    return line


def _duration(seconds: float) -> float:
    if not (math.isfinite(seconds) and seconds > 0.0):
        raise ValueError("duration must be positive")
    return seconds

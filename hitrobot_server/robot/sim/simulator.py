"""The simulated robot: physics, sensors and the robot's own software, stepped in sim time.

``Simulator(world, seed)`` owns everything; :meth:`Simulator.step` advances it. Time advances in
fixed ticks (``SimConfig.tick``, 40 Hz by default); ``step(dt)`` runs as many whole ticks as
``dt`` covers and carries the remainder, so a run depends only on the seed and the sequence of
commands, not on how the caller slices time. Each tick: the current action computes a velocity
command from the *believed* pose, the chassis moves in the *true* world (refusing collisions and
firing a bumper), odometry drift and the battery are updated. Every ``scan_period`` the lidar
measures from the true pose, localization re-estimates its quality, and (every ``map_period``,
when enabled) the explore map integrates the scan at the believed pose.

Its parts own their state and are handed values: :attr:`Simulator.actions`
(:class:`~.commands.Actions`: the current and recent actions, the motion requests),
:attr:`Simulator.map` (:class:`~.maps.RobotMap`: explore map, lines, blocked areas, home,
costmap) and its :class:`Neighbours` (the other robots of a shared world in its scan and
costmap). The backend's adapters (:mod:`.backend`) answer from them and from the chassis
queries here; bad arguments raise ``ValueError``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from ..model import (
    BasicSensorInfo,
    BasicSensorValue,
    DeviceInfo,
    HealthInfo,
    LaserScan,
    Odometry,
    Pose2D,
    PowerStatus,
    Rect,
    Twist2D,
)
from ..planning.costmap import Costmap
from ..planning.geometry import compose, inverse, wrap_angle
from ..planning.grid import distance_field
from ..planning.matching import LikelihoodField, RelocalizationSearch, scan_points
from .checks import checked_pose, checked_saved_robot
from .commands import Actions
from .config import SimConfig
from .health import HealthMonitor
from .kinematics import DiffDrive, DriveLimits
from .lidar import Lidar, RayCaster
from .localization import Localizer
from .mapping import ExploreMapper
from .maps import RobotMap
from .power import Battery, on_dock
from .sensors import SensorSuite, device_info
from .world import World

TRUE_FIELD_CELLS = 20
"""Reach (cells) of the ground-truth distance field used for collisions and matching."""


class Simulator:
    """One simulated robot in one world. Not thread-safe; drive it from one thread/loop.

    This class owns the world, the chassis, the sensors and the tick, and is what actions see
    (:class:`~.context.ActionContext`); its :attr:`actions` and its :attr:`map` are parts of
    their own.
    """

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
        mapper = ExploreMapper(spec)
        if cfg.prebuilt_map:
            mapper.seed(world.occupied, world.free)
        mapper.enabled = cfg.map_update
        self.map = RobotMap(mapper, world.dock_pose, cfg.costmap)
        clearance = np.where(world.occupied, 0.0, true_cells * res)
        self._field = LikelihoodField(spec, clearance, cfg.localization)
        stand = cfg.drive.radius + 0.5 * res + cfg.costmap.safety_margin
        self._standable = true_cells * res >= stand
        self._localizer = Localizer(self._field, cfg.localization, self._rng)
        self._battery = Battery(cfg.initial_battery, cfg.power)
        self._neighbours = Neighbours(cfg)
        self.actions = Actions(self, cfg.velocity_timeout)
        self._health = HealthMonitor()
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
        if self._health.emergency_stop:
            self._abort("emergency stop")
        action = self.actions.current
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
        ranges = self._neighbours.in_scan(ranges, true_pose, self._lidar.angles, self.others())
        ranges.flags.writeable = False  # handed out in LaserScan; shared by every reader
        believed = self._localizer.believed(true_pose)
        angles = self._lidar.angles
        self._scan = LaserScan(believed, angles, ranges, self.time)
        self._scan_odometry = true_pose
        self._sensors.update_sonars(true_pose)
        points = scan_points(angles, ranges, self.config.localization.match_points)
        self._localizer.update(self.config.scan_period, true_pose, points)
        if self._ticks % self._map_every == 0:
            self.map.mapper.integrate(believed, angles, ranges)

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
    def docked(self) -> bool:
        return on_dock(self._drive.pose, self.world.dock_pose, self.config.power)

    @property
    def latest_scan(self) -> LaserScan:
        return self._scan

    @property
    def home_pose(self) -> Pose2D | None:
        return self.map.home_pose

    def costmap(self) -> Costmap:
        """The planner's map; other robots in lidar range are obstacles in it (laid over the
        map's costmap again when one moved by a quarter metre)."""
        return self._neighbours.costmap(self.map.costmap(), self._drive.pose, self.others())

    def start_relocalization(self, area: Rect | None) -> RelocalizationSearch:
        scan = self._scan
        points = scan_points(scan.angles, scan.ranges, self.config.localization.match_points)
        return RelocalizationSearch(self._field, points, area, self._standable,
                                    self.config.localization)

    @property
    def scan_odometry(self) -> Pose2D:
        return self._scan_odometry

    def relocalize(self, match: Pose2D, at: Pose2D) -> None:
        """Believe ``match`` at odometry pose ``at``: the pose is the match plus the odometry
        motion since, whatever was believed (or forced with ``set_pose``) meanwhile."""
        now = self._drive.pose
        self._localizer.set_pose(compose(match, compose(inverse(at), now)), now)

    def report_relocalization(self, success: bool) -> None:
        self._health.relocalization_failed = not success

    # --- state queries -----------------------------------------------------------------------

    def odometry(self) -> Odometry:
        return Odometry(self.pose, Twist2D(self._drive.linear, 0.0, self._drive.angular), self.time)

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
        self._localizer.set_pose(checked_pose(pose), self._drive.pose)

    def power_status(self) -> PowerStatus:
        return self._battery.status(self.docked)

    def board_temperature(self) -> int:
        return 38 + round(4.0 * abs(self._drive.linear) / self.config.drive.max_linear)

    def sensors_info(self) -> list[BasicSensorInfo]:
        return list(self._sensors.info)

    def sensor_values(self) -> dict[int, BasicSensorValue]:
        return self._sensors.values(self.time)

    def device_info(self) -> DeviceInfo:
        return device_info(self.seed)

    def health(self) -> HealthInfo:
        return self._health.report(self._battery.low, self._localizer.enabled,
                                   self._localizer.quality)

    def clear_health_error(self, error_code: int) -> bool:
        """Acknowledge an error; conditions that still hold are reported again."""
        return self._health.clear(error_code)

    def load_composite_map(self, data: bytes, pose: Pose2D) -> None:
        """Install a composite map and set the believed pose; ``ValueError`` (and nothing
        changed) if either is invalid."""
        pose = checked_pose(pose)
        self.map.install(self.map.check_composite_map(data))
        self.set_pose(pose)

    # --- what the chassis keeps across a restart ---------------------------------------------

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
        pose, believed, battery, localization = checked_saved_robot(saved)
        if self._clearance(pose.x, pose.y) < self.config.drive.radius * 0.5:
            raise ValueError(f"the saved pose ({pose.x:.2f}, {pose.y:.2f}) is inside an obstacle")
        self._drive.pose = pose
        self._drive.linear = self._drive.angular = 0.0
        self._localizer.set_pose(believed, pose)
        self.localization_enabled = localization
        self._battery.percentage = battery
        self._sense()

    # --- the simulator's own controls (see :mod:`.controls`) ---------------------------------

    def set_battery(self, percent: float) -> float:
        """Set the state of charge (0–100 %); returns what it is now."""
        return self._battery.set(percent)

    def kidnap(self, true_pose: Pose2D) -> None:
        """Carry the robot to ``true_pose`` without telling it: its believed pose stays where it
        was, so its scans stop matching the map and its localization quality falls."""
        checked_pose(true_pose)
        if self._clearance(true_pose.x, true_pose.y) <= self.config.drive.radius:
            raise ValueError(f"({true_pose.x:.2f}, {true_pose.y:.2f}) is not free floor")
        believed = self.pose
        self._abort("kidnapped")
        self._drive.pose = true_pose
        self._localizer.set_pose(believed, true_pose)

    def emergency_stop(self, pressed: bool) -> None:
        """Press (``True``) or release the emergency stop."""
        self._health.emergency_stop = bool(pressed)
        if pressed:
            self._abort("emergency stop")

    def _abort(self, reason: str) -> None:
        """End the running action and stop the wheels."""
        self.actions.abort(reason)
        self._drive.linear = self._drive.angular = 0.0


class Neighbours:
    """What the others' true poses do to this robot's scan and costmap; the costmap with them
    is kept until one moved by a quarter metre or the map's costmap changed."""

    def __init__(self, config: SimConfig) -> None:
        self._config = config
        self._cached: tuple[tuple, Costmap, Costmap] | None = None

    def in_scan(self, ranges: np.ndarray, origin: Pose2D, angles: np.ndarray,
                others: Sequence[Pose2D]) -> np.ndarray:
        """``ranges`` cut short where a beam meets another robot's disc."""
        if not others:
            return ranges
        return np.minimum(ranges, discs_along_rays(
            origin, angles, others, self._config.drive.radius, self._config.lidar.max_range))

    def costmap(self, base: Costmap, me: Pose2D, others: Sequence[Pose2D]) -> Costmap:
        """``base`` with the others in lidar range of ``me`` as obstacles."""
        reach = self._config.lidar.max_range
        seen = tuple((round(p.x * 4) / 4, round(p.y * 4) / 4) for p in others
                     if math.hypot(p.x - me.x, p.y - me.y) <= reach)
        if not seen:
            return base
        cached = self._cached
        if cached is None or cached[0] != seen or cached[1] is not base:
            cached = self._cached = (seen, base, with_robots(base, seen, self._config))
        return cached[2]


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

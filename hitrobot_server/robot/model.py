"""Value types exchanged across the robot backend boundary.

Plain dataclasses and enums, so the Slamware node, the simulator and a future Slamware REST
client share one vocabulary. Units and conventions follow Slamware: metres, radians, the map
frame, explore-map cells as raw bytes (0 unknown, 1-127 free, 128-255 occupied), and the REST
action status codes (not the C++ SDK ones), because the REST API is what a real-robot client
will speak.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np


class MapKind(enum.IntEnum):
    """Which of the robot's maps a map call addresses (slamware_ros_sdk ``MapKind``)."""

    EXPLORERMAP = 0
    SWEEPERMAP = 1
    UWBMAP = 2
    SLAMMAP = 3
    LOCALSLAMMAP = 4


class ArtifactUsage(enum.IntEnum):
    """What a line artifact is for (``ArtifactUsage``; REST ``walls`` / ``tracks``)."""

    VIRTUAL_WALL = 0
    VIRTUAL_TRACK = 1


class ActionDirection(enum.IntEnum):
    """Manual move directions of ``move_by_direction`` (``ActionDirection``)."""

    FORWARD = 0
    BACKWARD = 1
    TURNRIGHT = 2
    TURNLEFT = 3


class LocalizationMovement(enum.IntEnum):
    """How the robot may move while recovering localization (``LocalizationMovement``)."""

    NO_MOVE = 0
    ROTATE_ONLY = 1
    ANY = 2


class SensorType(enum.IntEnum):
    """Kinds of basic sensors (``SensorType``)."""

    BUMPER = 0
    CLIFF = 1
    SONAR = 2
    DEPTH_CAMERA = 3
    WALL_SENSOR = 4
    MAG_TAPE_DETECTOR = 5


class ImpactType(enum.IntEnum):
    """Whether a basic sensor reports a switch or a measurement (``ImpactType``)."""

    DIGITAL = 0
    ANALOG = 1


class MoveOptionFlag(enum.IntFlag):
    """Bits of ``MoveOptionFlag.flags``; values are the SDK's, passed through unchanged."""

    NONE = 0
    APPENDING = 1
    MILESTONE = 2
    NO_SMOOTH = 4
    KEY_POINTS = 8
    PRECISE = 16
    WITH_YAW = 32
    RETURN_UNREACHABLE_DIRECTLY = 64
    KEY_POINTS_WITH_OA = 128


class NavigationMode(enum.IntEnum):
    """The REST ``move_options.mode`` / SDK ``NavigationMode`` (free, strict or priority track)."""

    FREE = 0
    STRICT_VIRTUAL_TRACK = 1
    PRIORITY_VIRTUAL_TRACK = 2


class ActionStatus(enum.IntEnum):
    """REST ``ActionState.status``: there is no 2, and an action is finished only at ``DONE``."""

    NEW_BORN = 0
    WORKING = 1
    PAUSED = 3
    DONE = 4


class ActionResult(enum.IntEnum):
    """REST ``ActionState.result``; meaningful once the status is ``DONE``."""

    SUCCESS = 0
    FAILED = -1
    ABORTED = -2


class DockingStatus(enum.Enum):
    """REST ``dockingStatus`` strings."""

    UNKNOWN = "unknown"
    ON_DOCK = "on_dock"
    NOT_ON_DOCK = "not_on_dock"


class PowerStage(enum.Enum):
    """REST ``powerStage`` strings (Slamware's own spelling of "shutingdown" kept)."""

    UNKNOWN = "unknown"
    STARTING = "starting"
    RUNNING = "running"
    RESTARTING = "restarting"
    SHUTTING_DOWN = "shutingdown"
    ERROR = "error"


class SleepMode(enum.Enum):
    """REST ``sleepMode`` strings."""

    UNKNOWN = "unknown"
    AWAKE = "awake"
    WAKING_UP = "waking_up"
    ASLEEP = "asleep"


class HealthLevel(enum.IntEnum):
    """Severity of a health error (REST ``baseError[].level``)."""

    HEALTHY = 0
    WARN = 1
    ERROR = 2
    FATAL = 4


class HealthComponent(enum.IntEnum):
    """Subsystem a health error belongs to (REST ``baseError[].component``)."""

    USER = 0
    SYSTEM = 1
    POWER = 2
    MOTION = 3
    SENSOR = 4


def health_error_code(level: HealthLevel, component: HealthComponent, code: int) -> int:
    """Compose a Slamware ``errorCode``: level in bits 24-31, component 16-23, own code 0-15."""
    return (int(level) << 24) | (int(component) << 16) | (code & 0xFFFF)


@dataclass(frozen=True, slots=True)
class Point2D:
    """A position in the map frame, metres."""

    x: float
    y: float


@dataclass(frozen=True, slots=True)
class Pose2D:
    """A planar pose in the map frame: metres and radians (yaw counter-clockwise from +x)."""

    x: float
    y: float
    yaw: float


@dataclass(frozen=True, slots=True)
class Twist2D:
    """Body-frame velocity: ``vx`` forward, ``vy`` left (0 on a differential drive), ``omega``."""

    vx: float
    vy: float
    omega: float


@dataclass(frozen=True, slots=True)
class Odometry:
    """The robot's reported pose with its current velocity, stamped in backend seconds."""

    pose: Pose2D
    twist: Twist2D
    stamp: float


@dataclass(frozen=True, slots=True)
class Rect:
    """An axis-aligned map rectangle: lower-left corner plus size (``RectFlt32``)."""

    x: float
    y: float
    width: float
    height: float

    @property
    def is_empty(self) -> bool:
        """True when the rectangle has no area, which callers use to mean "everywhere"."""
        return self.width <= 0.0 or self.height <= 0.0


@dataclass(frozen=True, slots=True, eq=False)
class LaserScan:
    """One lidar frame: ``angles`` relative to the robot's heading, ``ranges`` in metres with
    ``inf`` for beams without a return, and the pose the robot believed it had when the frame
    was taken (project points with this pose, as the Slamware spec advises)."""

    pose: Pose2D
    angles: np.ndarray
    ranges: np.ndarray
    stamp: float

    @property
    def valid(self) -> np.ndarray:
        """Mask of beams that returned."""
        return np.isfinite(self.ranges)


@dataclass(frozen=True, slots=True, eq=False)
class MapRegion:
    """A window of an explore map: ``cells[row, col]`` uint8, row 0 at the minimum y, the origin
    being the lower-left corner of cell (0, 0)."""

    origin_x: float
    origin_y: float
    resolution: float
    cells: np.ndarray

    @property
    def width(self) -> int:
        return int(self.cells.shape[1])

    @property
    def height(self) -> int:
        return int(self.cells.shape[0])


@dataclass(frozen=True, slots=True)
class PowerStatus:
    """Battery and dock state as the REST ``power/status`` reports it."""

    battery_percentage: int
    is_charging: bool
    is_dc_in: bool
    docking_status: DockingStatus
    power_stage: PowerStage = PowerStage.RUNNING
    sleep_mode: SleepMode = SleepMode.AWAKE


@dataclass(frozen=True, slots=True)
class BasicSensorInfo:
    """A bumper, cliff sensor or sonar and where it is mounted (pose in the robot frame)."""

    id: int
    sensor_type: SensorType
    impact_type: ImpactType
    install_pose: Pose2D
    refresh_freq: float


@dataclass(frozen=True, slots=True)
class BasicSensorValue:
    """One reading. Digital sensors read 0.0 when triggered (the SDK convention the ROS node
    relies on); sonars read a range in metres."""

    is_in_impact: bool
    value: float


@dataclass(frozen=True, slots=True)
class DeviceInfo:
    """Identity strings published once per connection (``RobotDeviceInfo``)."""

    device_id: str
    model_id: int
    model_name: str
    manufacturer_id: int
    manufacturer_name: str
    hardware_version: str
    software_version: str
    sdp_version: str
    sdk_version: str


@dataclass(frozen=True, slots=True)
class HealthError:
    """One entry of the REST ``baseError`` list."""

    id: int
    component: HealthComponent
    level: HealthLevel
    error_code: int
    message: str


@dataclass(frozen=True, slots=True)
class HealthInfo:
    """The REST ``robot/health`` answer."""

    has_warning: bool
    has_error: bool
    has_fatal: bool
    errors: tuple[HealthError, ...]

    @classmethod
    def from_errors(cls, errors: tuple[HealthError, ...]) -> HealthInfo:
        """Derive the three summary flags from the error levels."""
        levels = {e.level for e in errors}
        return cls(
            has_warning=HealthLevel.WARN in levels,
            has_error=HealthLevel.ERROR in levels,
            has_fatal=HealthLevel.FATAL in levels,
            errors=errors,
        )


@dataclass(frozen=True, slots=True)
class Line:
    """A virtual wall or track segment with the id the robot knows it by."""

    id: int
    start: Point2D
    end: Point2D


@dataclass(frozen=True, slots=True)
class MoveOptions:
    """Motion options: the ROS ``MoveOptions`` (flags, speed ratio) plus the SDK/REST extras.

    ``speed_ratio`` scales the maximum speeds (clamped to 0.1-1.0); ``acceptable_precision``
    overrides the arrival tolerance in metres; ``fail_retry_count`` bounds replanning;
    ``planning_area`` confines path planning to a map rectangle (the map manager's "fast
    planning"; a backend without such a restriction may ignore it).
    """

    flags: MoveOptionFlag = MoveOptionFlag.NONE
    speed_ratio: float | None = None
    mode: NavigationMode = NavigationMode.FREE
    acceptable_precision: float | None = None
    fail_retry_count: int | None = None
    planning_area: Rect | None = None


@dataclass(frozen=True, slots=True)
class ActionInfo:
    """A snapshot of a motion action, shaped like the REST ``ActionInfo``."""

    action_id: int
    action_name: str
    stage: str
    status: ActionStatus
    result: ActionResult
    reason: str

    @property
    def done(self) -> bool:
        return self.status == ActionStatus.DONE

    @property
    def succeeded(self) -> bool:
        return self.done and self.result == ActionResult.SUCCESS

"""Slamware REST JSON shapes ⇄ the backend model, both directions, pure functions.

The client reads what a robot sends with ``*_from`` functions and builds request bodies with
``*_json``; the sim-device does the opposite with the same functions, so the two cannot drift.
Readers are tolerant where real robots and gateways are known to differ (a bare ``0``/``1`` for
a laser point's ``valid``, status ``2`` for "paused" on some firmware, an action "gravestone"
without name or stage, snake_case health keys, unknown enum strings) and strict where a wrong
guess would mislead (a non-finite pose, a missing coordinate): those raise :class:`ShapeError`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ..backend import ACTION_PREFIX
from ..model import (
    ActionDirection,
    ActionInfo,
    ActionResult,
    ActionStatus,
    DeviceInfo,
    DockingStatus,
    HealthComponent,
    HealthError,
    HealthInfo,
    HealthLevel,
    LaserScan,
    Line,
    LocalizationMovement,
    MoveOptionFlag,
    MoveOptions,
    NavigationMode,
    Point2D,
    Pose2D,
    PowerStage,
    PowerStatus,
    Rect,
    SleepMode,
    Twist2D,
)

log = logging.getLogger(__name__)


class ShapeError(ValueError):
    """A JSON value that does not have the shape the REST API documents."""


# --- scalars ---------------------------------------------------------------------------------


def number(value: Any, what: str) -> float:
    """A finite JSON number (booleans are not numbers)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ShapeError(f"{what} must be a number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ShapeError(f"{what} must be finite, got {value!r}")
    return out


def integer(value: Any, what: str) -> int:
    out = number(value, what)
    if out != int(out):
        raise ShapeError(f"{what} must be an integer, got {value!r}")
    return int(out)


def boolean(value: Any, what: str) -> bool:
    """A JSON boolean; ``0``/``1`` are accepted too (some gateways send them)."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    raise ShapeError(f"{what} must be a boolean, got {value!r}")


def obj(value: Any, what: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ShapeError(f"{what} must be an object, got {type(value).__name__}")
    return value


def array(value: Any, what: str) -> list:
    if not isinstance(value, list):
        raise ShapeError(f"{what} must be an array, got {type(value).__name__}")
    return value


def _pick(d: Mapping[str, Any], *names: str, default: Any = None) -> Any:
    """The first of several spellings present in ``d``."""
    for name in names:
        if name in d:
            return d[name]
    return default


# --- geometry --------------------------------------------------------------------------------


def point_json(p: Point2D) -> dict:
    return {"x": float(p.x), "y": float(p.y)}


def location_json(p: Point2D) -> dict:
    return {"x": float(p.x), "y": float(p.y), "z": 0.0}


def point_from(value: Any, what: str = "point") -> Point2D:
    d = obj(value, what)
    return Point2D(number(d.get("x"), f"{what}.x"), number(d.get("y"), f"{what}.y"))


def pose3d_json(p: Pose2D) -> dict:
    """A ``Pose3D``: a planar robot has z, pitch and roll 0."""
    return {"x": float(p.x), "y": float(p.y), "z": 0.0,
            "yaw": float(p.yaw), "pitch": 0.0, "roll": 0.0}


def pose_from(value: Any, what: str = "pose") -> Pose2D:
    """A ``Pose3D`` or ``Pose2D`` (flat ``x, y, yaw``); z, pitch and roll are ignored (so their
    spelling, e.g. the wrapper docs' "picth", does not matter). A missing yaw reads as 0."""
    d = obj(value, what)
    yaw = d.get("yaw", 0.0)
    return Pose2D(number(d.get("x"), f"{what}.x"), number(d.get("y"), f"{what}.y"),
                  number(yaw, f"{what}.yaw"))


def rect_json(r: Rect) -> dict:
    return {"x": float(r.x), "y": float(r.y), "width": float(r.width), "height": float(r.height)}


def rect_from(value: Any, what: str = "rectangle") -> Rect:
    d = obj(value, what)
    return Rect(number(d.get("x"), f"{what}.x"), number(d.get("y"), f"{what}.y"),
                number(d.get("width"), f"{what}.width"),
                number(d.get("height"), f"{what}.height"))


def path_json(points: Iterable[Point2D]) -> dict:
    """``PathPoints``: ``{"path_points": [[x, y], ...]}``."""
    return {"path_points": [[float(p.x), float(p.y)] for p in points]}


def path_from(value: Any, what: str = "path") -> list[Point2D]:
    """``PathPoints``; ``{x, y}`` objects are accepted as well as ``[x, y]`` pairs."""
    points = array(obj(value, what).get("path_points", []), f"{what}.path_points")
    out = []
    for i, p in enumerate(points):
        if isinstance(p, list) and len(p) >= 2:
            out.append(Point2D(number(p[0], f"{what}[{i}][0]"), number(p[1], f"{what}[{i}][1]")))
        else:
            out.append(point_from(p, f"{what}[{i}]"))
    return out


def speed_json(t: Twist2D) -> dict:
    return {"vx": float(t.vx), "vy": float(t.vy), "omega": float(t.omega)}


def speed_from(value: Any) -> Twist2D:
    d = obj(value, "speed")
    return Twist2D(number(d.get("vx", 0.0), "speed.vx"), number(d.get("vy", 0.0), "speed.vy"),
                   number(d.get("omega", 0.0), "speed.omega"))


# --- laser -----------------------------------------------------------------------------------


def laser_scan_json(scan: LaserScan) -> dict:
    """``{"pose": Pose3D, "laser_points": [{distance, angle, valid}]}``; a beam without a return
    is sent with ``valid: false`` and distance 0 (JSON has no infinity)."""
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    valid = np.isfinite(ranges) & (ranges > 0.0)
    distances = np.where(valid, ranges, 0.0).tolist()
    angles = np.asarray(scan.angles, dtype=np.float64).tolist()
    return {
        "pose": pose3d_json(scan.pose),
        "laser_points": [{"distance": d, "angle": a, "valid": v}
                         for d, a, v in zip(distances, angles, valid.tolist(), strict=True)],
    }


def laser_scan_from(value: Any, stamp: float) -> LaserScan:
    """The scan with the pose the robot had *when the frame was observed* (the spec's advice),
    points in the order sent (ascending or descending; the node handles both). Invalid points,
    non-positive and non-finite distances become ``inf``."""
    d = obj(value, "laserscan")
    pose = pose_from(d.get("pose"), "laserscan.pose")
    points = array(d.get("laser_points", []), "laserscan.laser_points")
    angles = np.empty(len(points), dtype=np.float64)
    ranges = np.empty(len(points), dtype=np.float64)
    for i, p in enumerate(points):
        if not isinstance(p, Mapping):
            raise ShapeError(f"laserscan.laser_points[{i}] must be an object")
        angles[i] = number(p.get("angle"), f"laserscan.laser_points[{i}].angle")
        dist = p.get("distance")
        ok = boolean(p.get("valid", True), f"laserscan.laser_points[{i}].valid")
        if ok and isinstance(dist, int | float) and not isinstance(dist, bool) \
                and math.isfinite(dist) and dist > 0.0:
            ranges[i] = float(dist)
        else:
            ranges[i] = math.inf
    return LaserScan(pose, angles, ranges, stamp)


# --- system ----------------------------------------------------------------------------------


def _enum_value(enum_type, value: Any, default):
    try:
        return enum_type(value)
    except ValueError:
        return default


def power_json(p: PowerStatus) -> dict:
    return {
        "batteryPercentage": int(p.battery_percentage),
        "dockingStatus": p.docking_status.value,
        "isCharging": bool(p.is_charging),
        "isDCConnected": bool(p.is_dc_in),
        "powerStage": p.power_stage.value,
        "sleepMode": p.sleep_mode.value,
    }


def power_from(value: Any) -> PowerStatus:
    """``power/status``; unknown strings (other firmware) read as ``UNKNOWN``."""
    d = obj(value, "power status")
    return PowerStatus(
        battery_percentage=round(number(d.get("batteryPercentage"), "batteryPercentage")),
        is_charging=boolean(d.get("isCharging", False), "isCharging"),
        is_dc_in=boolean(d.get("isDCConnected", False), "isDCConnected"),
        docking_status=_enum_value(DockingStatus, d.get("dockingStatus"), DockingStatus.UNKNOWN),
        power_stage=_enum_value(PowerStage, d.get("powerStage"), PowerStage.UNKNOWN),
        sleep_mode=_enum_value(SleepMode, d.get("sleepMode"), SleepMode.UNKNOWN),
    )


def device_info_json(info: DeviceInfo) -> dict:
    """``robot/info``: note ``deviceID`` with a capital D."""
    return {
        "manufacturerId": info.manufacturer_id,
        "manufacturerName": info.manufacturer_name,
        "modelId": info.model_id,
        "modelName": info.model_name,
        "deviceID": info.device_id,
        "hardwareVersion": info.hardware_version,
        "softwareVersion": info.software_version,
    }


def device_info_from(value: Any, sdk_version: str) -> DeviceInfo:
    """``robot/info``. REST has no SDP or SDK version: the SDP version is the robot's software
    version (the SDP is its firmware) and the SDK version is the caller's, i.e. this client."""
    d = obj(value, "robot info")
    software = str(d.get("softwareVersion", ""))
    return DeviceInfo(
        device_id=str(_pick(d, "deviceID", "deviceId", "device_id", default="")),
        model_id=integer(d.get("modelId", 0), "modelId"),
        model_name=str(d.get("modelName", "")),
        manufacturer_id=integer(d.get("manufacturerId", 0), "manufacturerId"),
        manufacturer_name=str(d.get("manufacturerName", "")),
        hardware_version=str(d.get("hardwareVersion", "")),
        software_version=software,
        sdp_version=software,
        sdk_version=sdk_version,
    )


def health_json(h: HealthInfo) -> dict:
    return {
        "hasWarning": h.has_warning,
        "hasError": h.has_error,
        "hasFatal": h.has_fatal,
        "baseError": [{"id": e.id, "component": int(e.component), "errorCode": e.error_code,
                       "level": int(e.level), "message": e.message} for e in h.errors],
    }


def health_from(value: Any) -> HealthInfo:
    """``robot/health``. Camel case per the spec; snake case (seen in a mock) is accepted.
    A component or level outside the model's enums (e.g. 255 "unknown") is taken from the
    ``errorCode`` bits (level 24-31, component 16-23), else SYSTEM / ERROR."""
    d = obj(value, "health")
    errors = []
    for i, e in enumerate(array(_pick(d, "baseError", "base_error", default=[]), "baseError")):
        e = obj(e, f"baseError[{i}]")
        code = integer(_pick(e, "errorCode", "error_code", default=0), f"baseError[{i}].errorCode")
        component = _enum_value(HealthComponent, e.get("component"), None)
        if component is None:
            component = _enum_value(HealthComponent, (code >> 16) & 0xFF, HealthComponent.SYSTEM)
        level = _enum_value(HealthLevel, e.get("level"), None)
        if level is None:
            level = _enum_value(HealthLevel, (code >> 24) & 0xFF, HealthLevel.ERROR)
        errors.append(HealthError(integer(e.get("id", i), f"baseError[{i}].id"), component,
                                  level, code, str(e.get("message", ""))))
    derived = HealthInfo.from_errors(tuple(errors))

    def flag(camel: str, snake: str, fallback: bool) -> bool:
        raw = _pick(d, camel, snake)
        return fallback if raw is None else boolean(raw, camel)

    return HealthInfo(
        has_warning=flag("hasWarning", "has_warning", derived.has_warning),
        has_error=flag("hasError", "has_error", derived.has_error),
        has_fatal=flag("hasFatal", "has_fatal", derived.has_fatal),
        errors=derived.errors,
    )


def core_ready(value: Any) -> bool:
    """Whether ``capabilities`` says the core agent is up (``enabled`` is false while the robot
    starts); a list without the core entry counts as ready."""
    for entry in array(value, "capabilities"):
        if isinstance(entry, Mapping) and entry.get("name") == "slamware.agent.core":
            return entry.get("enabled", True) is not False
    return True


# --- actions ---------------------------------------------------------------------------------

MOVE_TO = ACTION_PREFIX + "MoveToAction"
SERIES_MOVE_TO = ACTION_PREFIX + "SeriesMoveToAction"
MOVE_BY = ACTION_PREFIX + "MoveByAction"
ROTATE_TO = ACTION_PREFIX + "RotateToAction"
ROTATE = ACTION_PREFIX + "RotateAction"
GO_HOME = ACTION_PREFIX + "GoHomeAction"
RECOVER_LOCALIZATION = ACTION_PREFIX + "RecoverLocalizationAction"

REST_FLAGS: dict[int, str] = {
    int(MoveOptionFlag.PRECISE): "precise",
    int(MoveOptionFlag.WITH_YAW): "with_yaw",
    512: "fail_retry_count",
    1024: "find_path_ignoring_dynamic_obstacles",
    2048: "with_directed_virtual_track",
}
"""SDK ``MoveOptionFlag`` bits that have a REST ``move_options.flags`` string."""
FLAG_BITS = {name: bit for bit, name in REST_FLAGS.items()}
MODE_BITS: dict[int, NavigationMode] = {
    int(MoveOptionFlag.KEY_POINTS): NavigationMode.STRICT_VIRTUAL_TRACK,
    int(MoveOptionFlag.KEY_POINTS_WITH_OA): NavigationMode.PRIORITY_VIRTUAL_TRACK,
}
"""Deprecated SDK bits whose meaning lives on as the REST ``mode``."""
DROPPED_FLAGS = (MoveOptionFlag.MILESTONE | MoveOptionFlag.NO_SMOOTH
                 | MoveOptionFlag.RETURN_UNREACHABLE_DIRECTLY)
"""Bits REST cannot express (``APPENDING`` is emulated by the client, not sent)."""
STATUS_CODES = {0: ActionStatus.NEW_BORN, 1: ActionStatus.WORKING, 2: ActionStatus.PAUSED,
                3: ActionStatus.PAUSED, 4: ActionStatus.DONE}
"""REST ``state.status``; 2 is "paused" on some firmware and emulators, 3 in the spec."""
MOVEMENT_NAMES = {LocalizationMovement.ROTATE_ONLY: "RotateOnly",
                  LocalizationMovement.NO_MOVE: "NoMove"}


def move_options_json(options: MoveOptions | None, yaw: float = 0.0) -> dict:
    """REST ``move_options``: flag bits become strings, ``KEY_POINTS`` / ``KEY_POINTS_WITH_OA``
    become ``mode`` 1 / 2 (unless a mode is set), ``yaw`` is sent with ``with_yaw`` only.
    ``MILESTONE``, ``NO_SMOOTH`` and ``RETURN_UNREACHABLE_DIRECTLY`` have no REST form."""
    options = options or MoveOptions()
    bits = int(options.flags)
    flags = [name for bit, name in REST_FLAGS.items() if bits & bit]
    if options.fail_retry_count is not None and "fail_retry_count" not in flags:
        flags.append("fail_retry_count")
    mode = options.mode
    if mode == NavigationMode.FREE:
        for bit, implied in MODE_BITS.items():
            if bits & bit:
                mode = implied
                break
    out: dict[str, Any] = {"mode": int(mode), "flags": flags}
    if bits & MoveOptionFlag.WITH_YAW:
        out["yaw"] = float(yaw)
    if options.speed_ratio is not None:
        out["speed_ratio"] = float(options.speed_ratio)
    if options.acceptable_precision is not None:
        out["acceptable_precision"] = float(options.acceptable_precision)
    if options.fail_retry_count is not None:
        out["fail_retry_count"] = int(options.fail_retry_count)
    return out


def move_options_from(value: Any) -> tuple[MoveOptions, float]:
    """REST ``move_options`` back to options and the final yaw (0 without one)."""
    if value is None:
        return MoveOptions(), 0.0
    d = obj(value, "move_options")
    bits = 0
    for name in array(d.get("flags", []), "move_options.flags"):
        if name not in FLAG_BITS:
            raise ShapeError(f"move_options.flags: unknown flag {name!r}")
        bits |= FLAG_BITS[name]
    try:
        mode = NavigationMode(integer(d.get("mode", 0), "move_options.mode"))
    except ValueError as exc:
        raise ShapeError(f"move_options.mode: unsupported mode {d.get('mode')!r}") from exc

    def optional(name: str, convert) -> Any:
        raw = d.get(name)
        return None if raw is None else convert(raw, f"move_options.{name}")

    options = MoveOptions(
        flags=MoveOptionFlag(bits),
        speed_ratio=optional("speed_ratio", number),
        mode=mode,
        acceptable_precision=optional("acceptable_precision", number),
        fail_retry_count=optional("fail_retry_count", integer),
    )
    yaw = number(d.get("yaw", 0.0), "move_options.yaw")
    return options, yaw


def action_request(name: str, options: Mapping[str, Any]) -> dict:
    return {"action_name": name, "options": dict(options)}


def move_to_request(targets: Sequence[Point2D], options: MoveOptions | None, yaw: float) -> dict:
    move = move_options_json(options, yaw)
    if len(targets) == 1:
        return action_request(MOVE_TO, {"target": location_json(targets[0]),
                                        "move_options": move})
    return action_request(SERIES_MOVE_TO, {"targets": [location_json(t) for t in targets],
                                           "move_options": move})


def move_by_request(direction: ActionDirection | None, theta: float | None, duration: float,
                    options: MoveOptions | None = None) -> dict:
    """``MoveByAction``: a direction 0-3 or a ``theta``, for ``duration`` (sent in ms)."""
    body: dict[str, Any] = {"duration": max(1, round(duration * 1000.0))}
    if direction is not None:
        body["direction"] = int(direction)
    else:
        body["theta"] = float(theta if theta is not None else 0.0)
    if options is not None and options != MoveOptions():
        body["move_options"] = move_options_json(options)
    return action_request(MOVE_BY, body)


def rotate_request(angle: float, absolute: bool, options: MoveOptions | None = None) -> dict:
    body: dict[str, Any] = {"angle": float(angle)}
    if options is not None and options != MoveOptions():
        body["move_options"] = move_options_json(options)
    return action_request(ROTATE_TO if absolute else ROTATE, body)


def go_home_request(options: MoveOptions | None = None) -> dict:
    """``GoHomeAction``: plain ``{}`` options (accepted in practice) unless move options are
    given, then ``gohome_options`` with ``flags: "dock"`` and the move options."""
    if options is None or options == MoveOptions():
        return action_request(GO_HOME, {})
    return action_request(GO_HOME, {"gohome_options": {
        "flags": "dock", "move_options": move_options_json(options)}})


def recover_request(area: Rect | None, max_time_ms: int | None,
                    movement: LocalizationMovement | None) -> dict:
    """``RecoverLocalizationAction``: no ``area`` searches the whole map. ``ANY`` movement has
    no REST form and is left to the robot's default."""
    body: dict[str, Any] = {}
    if area is not None and not area.is_empty:
        body["area"] = rect_json(area)
    reloc: dict[str, Any] = {}
    if max_time_ms is not None:
        reloc["max_recover_time"] = int(max_time_ms)
    if movement in MOVEMENT_NAMES:
        reloc["recover_movement_type"] = MOVEMENT_NAMES[movement]
    if reloc:
        body["relocalization_options"] = reloc
    return action_request(RECOVER_LOCALIZATION, body)


def movement_from(value: Any) -> LocalizationMovement | None:
    if value is None:
        return None
    for movement, name in MOVEMENT_NAMES.items():
        if value == name:
            return movement
    raise ShapeError(f"recover_movement_type must be RotateOnly or NoMove, got {value!r}")


def action_json(a: ActionInfo) -> dict:
    return {"action_id": a.action_id, "action_name": a.action_name, "stage": a.stage,
            "state": {"status": int(a.status), "result": int(a.result), "reason": a.reason}}


def action_from(value: Any) -> ActionInfo:
    """An ``ActionInfo``, or an ``ActionGravestone`` (no name, no stage) for a finished action.
    ``stage`` is free text, passed through. A status the spec does not know counts as working
    (never as finished); a result it does not know counts as failed."""
    d = obj(value, "action")
    state = obj(d.get("state", {}), "action.state")
    raw_status = integer(state.get("status", 0), "action.state.status")
    status = STATUS_CODES.get(raw_status)
    if status is None:
        log.warning("action %s has unknown status %d; treating it as working",
                    d.get("action_id"), raw_status)
        status = ActionStatus.WORKING
    raw_result = integer(state.get("result", 0), "action.state.result")
    result = _enum_value(ActionResult, raw_result, ActionResult.FAILED)
    return ActionInfo(
        action_id=integer(d.get("action_id"), "action.action_id"),
        action_name=str(d.get("action_name") or ""),
        stage=str(d.get("stage") or ""),
        status=status,
        result=result,
        reason=str(state.get("reason") or ""),
    )


# --- artifacts -------------------------------------------------------------------------------


def line_json(line: Line) -> dict:
    return {"id": int(line.id), "start": point_json(line.start), "end": point_json(line.end),
            "metadata": {}}


def line_from(value: Any, what: str = "line") -> Line:
    """A ``Line``; its metadata (e.g. Bézier control points as strings) is not kept."""
    d = obj(value, what)
    return Line(integer(d.get("id", 0), f"{what}.id"), point_from(d.get("start"), f"{what}.start"),
                point_from(d.get("end"), f"{what}.end"))


def lines_from(value: Any) -> list[Line]:
    return [line_from(v, f"lines[{i}]") for i, v in enumerate(array(value, "lines"))]


BLOCKED_METADATA = {"display_name": "hitrobot blocked area", "source": "hitrobot-server"}
"""Marks the forbidden rectangle areas this client owns, so it replaces only its own."""
COVER_STEP = 0.1
"""Height (m) of the strips that cover a blocked polygon which is not a rectangle."""


def owned_area_ids(value: Any) -> list[int]:
    """Ids of the rectangle areas in a ``GET rectangle-areas`` answer that carry our
    :data:`BLOCKED_METADATA` marker."""
    out = []
    for i, entry in enumerate(array(value, "rectangle areas")):
        entry = obj(entry, f"rectangle areas[{i}]")
        metadata = entry.get("metadata")
        if isinstance(metadata, Mapping) and metadata.get("source") == BLOCKED_METADATA["source"]:
            out.append(integer(entry.get("id"), f"rectangle areas[{i}].id"))
    return out


def rectangle_area_json(start: Point2D, end: Point2D, half_width: float,
                        metadata: Mapping[str, str] | None = None, area_id: int | None = None,
                        usage: str | None = None) -> dict:
    """A ``RectangleArea``: the rectangle around segment ``start``-``end``, ``half_width`` to
    either side."""
    out: dict[str, Any] = {"area": {"start": point_json(start), "end": point_json(end),
                                    "half_width": float(half_width)},
                           "metadata": dict(metadata or {})}
    if area_id is not None:
        out["id"] = area_id
    if usage is not None:
        out["usage"] = usage
    return out


def rectangle_area_from(value: Any, what: str = "area") -> tuple[Point2D, Point2D, float]:
    d = obj(obj(value, what).get("area"), f"{what}.area")
    return (point_from(d.get("start"), f"{what}.area.start"),
            point_from(d.get("end"), f"{what}.area.end"),
            number(d.get("half_width"), f"{what}.area.half_width"))


def rectangle_corners(start: Point2D, end: Point2D, half_width: float) -> tuple[Point2D, ...]:
    """The four corners of a rectangle area (a square of side 2·half_width if start == end)."""
    dx, dy = end.x - start.x, end.y - start.y
    length = math.hypot(dx, dy)
    if length < 1e-9:
        h = half_width
        return (Point2D(start.x - h, start.y - h), Point2D(start.x + h, start.y - h),
                Point2D(start.x + h, start.y + h), Point2D(start.x - h, start.y + h))
    nx, ny = -dy / length * half_width, dx / length * half_width
    return (Point2D(start.x + nx, start.y + ny), Point2D(end.x + nx, end.y + ny),
            Point2D(end.x - nx, end.y - ny), Point2D(start.x - nx, start.y - ny))


def cover_polygon(polygon: Sequence[Point2D], step: float = COVER_STEP
                  ) -> list[tuple[Point2D, Point2D, float]]:
    """Rectangle areas ``(start, end, half_width)`` whose union covers ``polygon``.

    A rectangle (any orientation) is one exact area. Any other polygon is cut into horizontal
    strips ``step`` high; in each strip, every piece of the polygon becomes the axis-aligned
    rectangle spanning the piece's x-extent, and rectangles repeating in the strips above are
    merged. The cover contains the polygon and is nowhere more than one strip away from it.
    Fewer than three points, or no height, give a thin area along the points."""
    pts = list(polygon)
    if len(pts) >= 2 and pts[0] == pts[-1]:
        pts = pts[:-1]
    if not pts:
        return []
    thin = step / 4.0
    if len(pts) == 1:
        return [(pts[0], pts[0], thin)]
    exact = _rectangle(pts) if len(pts) == 4 else None
    if exact is not None:
        return [exact]
    ys = [p.y for p in pts]
    if len(pts) == 2 or max(ys) - min(ys) < 1e-9:
        left = min(pts, key=lambda p: (p.x, p.y))
        right = max(pts, key=lambda p: (p.x, p.y))
        return [(left, right, thin)]
    return _strips(pts, step)


def _rectangle(pts: list[Point2D]) -> tuple[Point2D, Point2D, float] | None:
    edges = [(pts[(i + 1) % 4].x - pts[i].x, pts[(i + 1) % 4].y - pts[i].y) for i in range(4)]
    lengths = [math.hypot(*e) for e in edges]
    if min(lengths) < 1e-9:
        return None
    for i in range(4):
        (ax, ay), (bx, by) = edges[i], edges[(i + 1) % 4]
        if abs(ax * bx + ay * by) > 1e-6 * lengths[i] * lengths[(i + 1) % 4]:
            return None
    if abs(lengths[0] - lengths[2]) > 1e-6 * lengths[0]:
        return None
    p0, p1, p2, p3 = pts
    start = Point2D((p0.x + p1.x) / 2.0, (p0.y + p1.y) / 2.0)
    end = Point2D((p3.x + p2.x) / 2.0, (p3.y + p2.y) / 2.0)
    return start, end, lengths[0] / 2.0


def _strips(pts: list[Point2D], step: float) -> list[tuple[Point2D, Point2D, float]]:
    n = len(pts)
    edges = [(pts[i], pts[(i + 1) % n]) for i in range(n) if pts[i].y != pts[(i + 1) % n].y]
    corners = sorted({p.y for p in pts})
    y_min, y_max = corners[0], corners[-1]

    def x_at(edge: tuple[Point2D, Point2D], y: float) -> float:
        a, b = edge
        return a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y)

    def pieces(lo: float, hi: float) -> list[tuple[float, float]]:
        """x-extents of the polygon's pieces between heights lo and hi (no corner between)."""
        mid = (lo + hi) / 2.0
        crossing = sorted((x_at(e, mid), e) for e in edges
                          if min(e[0].y, e[1].y) <= mid <= max(e[0].y, e[1].y))
        out = []
        for (_, left), (_, right) in zip(crossing[::2], crossing[1::2], strict=False):
            out.append((min(x_at(left, lo), x_at(left, hi)),
                        max(x_at(right, lo), x_at(right, hi))))
        return out

    rects: list[tuple[float, float, float, float]] = []  # x0, x1, y0, y1
    open_runs: dict[tuple[float, float], float] = {}  # (x0, x1) -> y where the run began
    count = max(1, math.ceil((y_max - y_min) / step - 1e-9))
    for k in range(count + 1):
        runs: list[tuple[float, float]] = []
        lo, hi = min(y_max, y_min + k * step), min(y_max, y_min + (k + 1) * step)
        if k < count:
            cuts = [lo, *(y for y in corners if lo < y < hi), hi]
            spans = sorted(span for a, b in zip(cuts, cuts[1:], strict=False) if b > a
                           for span in pieces(a, b))
            for x0, x1 in spans:  # union of overlapping spans
                if runs and x0 <= runs[-1][1]:
                    runs[-1] = (runs[-1][0], max(runs[-1][1], x1))
                else:
                    runs.append((x0, x1))
        keys = {(round(x0, 9), round(x1, 9)): (x0, x1) for x0, x1 in runs}
        for key in [key for key in open_runs if key not in keys]:
            began = open_runs.pop(key)
            rects.append((key[0], key[1], began, lo))
        for key in keys:
            open_runs.setdefault(key, lo)
    return [(Point2D(x0, (y0 + y1) / 2.0), Point2D(x1, (y0 + y1) / 2.0), (y1 - y0) / 2.0)
            for x0, x1, y0, y1 in rects]

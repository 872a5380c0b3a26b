"""``slamware_ros_sdk_server_node`` on the bus: the real node's topics, services and tf.

The node only talks to a :class:`~hitrobot_server.robot.capabilities.Robot`'s capabilities;
whether that is the simulator or a real robot over REST is not its business. Like the real
node, each publisher is a worker with its own period (≤ 0 disables it) and requests arrive on
topics; unlike the real node, a request we cannot carry out is reported to the client that sent
it as a ``status`` error.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Awaitable, Callable
from typing import Any

from ...bus.core import Bus
from ...bus.errors import ServiceError
from ...bus.requests import Reply
from ...bus.topics import Message, RequestRejected
from ...robot.backend import ACTION_PREFIX, BackendError
from ...robot.capabilities import Robot
from ...robot.model import (
    ActionDirection,
    ActionInfo,
    ActionResult,
    ArtifactUsage,
    Line,
    LocalizationMovement,
    MapKind,
    MoveOptionFlag,
    MoveOptions,
    Point2D,
    Pose2D,
    Rect,
)
from ...robot.motion import GOAL_FLAGS, follow
from ...robot.relocalization import GOOD_QUALITY, settled_quality
from ..base import RobotNode, require_finite
from ..ground import messages as m
from ..ground.mapsync import MapHolder, tiles, window
from ..ground.names import SLAMWARE_NODE
from ..ground.requests import answer, require_robot
from ..ground.slamware_params import SlamwareParams

log = logging.getLogger(__name__)

NODE_NAME = SLAMWARE_NODE
PKG = "slamware_ros_sdk"
KNOWN_FLAGS = 0xFF | 512 | 1024 | 2048  # the ROS msg's bits plus the SDK's newer ones


def _enum(path: str, value: int, enum_type) -> Any:
    try:
        member = enum_type(value)
    except ValueError:
        member = None
    if member is None or value < 0:
        names = ", ".join(f"{e.name}={e.value}" for e in enum_type if e.value >= 0)
        raise RequestRejected(f"field '{path}' must be one of {names}, got {value}")
    return member


def _move_options(msg: dict, path: str = "options") -> MoveOptions:
    flags = msg["opt_flags"]["flags"]
    if flags & ~KNOWN_FLAGS:
        raise RequestRejected(f"field '{path}.opt_flags.flags' has unknown bits {flags:#x}")
    ratio = msg["speed_ratio"]
    speed = None
    if ratio["is_valid"]:
        require_finite(f"{path}.speed_ratio.value", ratio["value"])
        if not 0.0 < ratio["value"] <= 1.0:
            raise RequestRejected(f"field '{path}.speed_ratio.value' must be in (0, 1]")
        speed = float(ratio["value"])
    return MoveOptions(flags=MoveOptionFlag(flags), speed_ratio=speed)


def _point(msg: dict, path: str) -> Point2D:
    require_finite(path, msg["x"], msg["y"])
    return Point2D(float(msg["x"]), float(msg["y"]))


def _quaternion_yaw(q: dict, path: str) -> float:
    require_finite(path, q["x"], q["y"], q["z"], q["w"])
    return m.yaw_of(q)


def _line(msg: dict, path: str) -> Line:
    start, end = _point(msg["start"], f"{path}.start"), _point(msg["end"], f"{path}.end")
    if math.hypot(end.x - start.x, end.y - start.y) < 1e-6:
        raise RequestRejected(f"field '{path}' is a line of zero length")
    return Line(int(msg["id"]), start, end)


class SlamwareNode(RobotNode):
    """Publishes the robot's state and executes requests exactly where the real node does."""

    def __init__(self, bus: Bus, robot: Robot, params: SlamwareParams | None = None):
        super().__init__(bus, NODE_NAME, robot.link)
        self.robot = robot
        self.params = params or SlamwareParams()
        self.map = MapHolder()
        self._sync_requested = True
        self._last_pose: Pose2D | None = None
        self._sensor_signature: tuple | None = None
        self._sensors: list = []  # the robot's sensors, refreshed by the info worker
        self._was_connected = False
        self._seq = 0
        p = self.params
        for name, value in p.as_dict().items():
            bus.params.set(f"{NODE_NAME}/{name}", value)

        self.topic_scan = m.slamware_topic(p.scan_topic)
        self.topic_odom = m.slamware_topic(p.odom_topic)
        self.scan_topics = self._with_alias(self.topic_scan, p.conventional_scan_topic)
        self.odom_topics = self._with_alias(self.topic_odom, p.conventional_odom_topic)
        self.topic_map = m.slamware_topic(p.map_topic)
        self.topic_map_info = m.slamware_topic(p.map_info_topic)
        self.topic_sensors_info = m.slamware_topic(p.basic_sensors_info_topic)
        self.topic_sensors_values = m.slamware_topic(p.basic_sensors_values_topic)
        self.topic_path = m.slamware_topic(p.path_topic)
        self.topic_state = m.slamware_topic("robot_basic_state")
        self.topic_walls = m.slamware_topic("virtual_walls")
        self.topic_tracks = m.slamware_topic("virtual_tracks")
        self.topic_device = m.slamware_topic("robot_device_info")
        for topic, type_name, latch in (
            *((t, "sensor_msgs/LaserScan", False) for t in self.scan_topics),
            *((t, "nav_msgs/Odometry", False) for t in self.odom_topics),
            (self.topic_map, "nav_msgs/OccupancyGrid", True),
            (self.topic_map_info, "nav_msgs/MapMetaData", True),
            (self.topic_sensors_info, f"{PKG}/BasicSensorInfoArray", True),
            (self.topic_sensors_values, f"{PKG}/BasicSensorValueDataArray", False),
            (self.topic_path, "nav_msgs/Path", False),
            (self.topic_state, f"{PKG}/RobotBasicState", True),
            (self.topic_walls, f"{PKG}/Line2DFlt32Array", True),
            (self.topic_tracks, f"{PKG}/Line2DFlt32Array", True),
            (self.topic_device, f"{PKG}/RobotDeviceInfo", True),
            ("/tf", "tf2_msgs/TFMessage", False),
        ):
            self.advertise(topic, type_name, latch=latch)

        requests: list[tuple[str, str, Callable[[Message], None]]] = [
            (m.slamware_topic(p.vel_control_topic), "geometry_msgs/Twist", self._on_cmd_vel),
            (m.slamware_topic(p.goal_topic), "geometry_msgs/PoseStamped", self._on_goal),
            ("sync_map", f"{PKG}/SyncMapRequest", self._on_sync_map),
            ("set_pose", "geometry_msgs/Pose", self._on_set_pose),
            ("recover_localization", f"{PKG}/RecoverLocalizationRequest", self._on_recover),
            ("clear_map", f"{PKG}/ClearMapRequest", self._on_clear_map),
            ("set_map_update", f"{PKG}/SetMapUpdateRequest", self._on_set_map_update),
            ("set_map_localization", f"{PKG}/SetMapLocalizationRequest", self._on_set_loc),
            ("move_by_direction", f"{PKG}/MoveByDirectionRequest", self._on_move_by_direction),
            ("move_by_theta", f"{PKG}/MoveByThetaRequest", self._on_move_by_theta),
            ("move_to", f"{PKG}/MoveToRequest", self._on_move_to),
            ("move_to_locations", f"{PKG}/MoveToLocationsRequest", self._on_move_to_locations),
            ("rotate_to", f"{PKG}/RotateToRequest", self._on_rotate_to),
            ("rotate", f"{PKG}/RotateRequest", self._on_rotate),
            ("go_home", f"{PKG}/GoHomeRequest", self._on_go_home),
            ("cancel_action", f"{PKG}/CancelActionRequest", self._on_cancel),
            ("add_line", f"{PKG}/AddLineRequest", self._on_add_line),
            ("add_lines", f"{PKG}/AddLinesRequest", self._on_add_lines),
            ("remove_line", f"{PKG}/RemoveLineRequest", self._on_remove_line),
            ("clear_lines", f"{PKG}/ClearLinesRequest", self._on_clear_lines),
            ("move_line", f"{PKG}/MoveLineRequest", self._on_move_line),
            ("move_lines", f"{PKG}/MoveLinesRequest", self._on_move_lines),
        ]
        for topic, type_name, handler in requests:
            self.subscribe(m.slamware_topic(topic), type_name, handler)

        self.service(m.slamware_topic("sync_get_stcm"), f"{PKG}/SyncGetStcm", self._sync_get_stcm)
        self.service(m.slamware_topic("sync_set_stcm"), f"{PKG}/SyncSetStcm", self._sync_set_stcm)

    @classmethod
    def _with_alias(cls, topic: str, alias: str) -> tuple[str, ...]:
        """The node's own topic, plus its conventional name when set and different."""
        alias = m.slamware_topic(alias) if alias else ""
        return (topic, alias) if alias and alias != topic else (topic,)

    # ------------------------------------------------------------------ lifecycle
    async def start(self) -> None:
        p = self.params
        workers: list[tuple[float, Callable[[], Awaitable[None]]]] = [
            (0.1, self._watch_connection),
            (p.robot_pose_pub_period, self._publish_pose),
            (p.scan_pub_period, self._publish_scan),
            (p.map_update_period, self._update_map),
            (p.map_pub_period, self._publish_map),
            (p.basic_sensors_info_update_period, self._publish_sensors_info),
            (p.basic_sensors_values_pub_period, self._publish_sensor_values),
            (p.path_pub_period, self._publish_path),
            (p.robot_basic_state_pub_period, self._publish_basic_state),
            (p.virtual_walls_pub_period, lambda: self._publish_lines(ArtifactUsage.VIRTUAL_WALL)),
            (p.virtual_tracks_pub_period,
             lambda: self._publish_lines(ArtifactUsage.VIRTUAL_TRACK)),
        ]
        for period, work in workers:
            if period > 0:  # the connection watch runs while the robot is away, too
                self.every(period, work, needs_robot=work != self._watch_connection)

    async def _watch_connection(self) -> None:
        connected = self.link.connected
        if connected and not self._was_connected:
            log.info("robot connected")
            self._sync_requested = True
            self.map.resolution = None
            self._sensors = []  # a (re)connected robot may have other sensors
            try:
                info = await self.robot.sensors.get_device_info()
                self.publish(self.topic_device, m.device_info(info))
            except BackendError as exc:
                log.warning("device info: %s", exc)
                return  # try again on the next tick
        elif not connected and self._was_connected:
            log.warning("robot disconnected; retrying every %d ms", self.params.reconn_wait_ms)
        self._was_connected = connected

    # ------------------------------------------------------------------ publishers
    async def _publish_pose(self) -> None:
        odo = await self.robot.sensors.get_odometry()
        p = self.params
        self._last_pose = odo.pose
        now = self.bus.clock()
        odom = {
            "header": m.header(p.odom_frame, now),
            "child_frame_id": p.robot_frame,
            "pose": {"pose": m.pose(odo.pose), "covariance": [0.0] * 36},
            "twist": {"twist": {"linear": {"x": odo.twist.vx, "y": odo.twist.vy, "z": 0.0},
                                "angular": {"x": 0.0, "y": 0.0, "z": odo.twist.omega}},
                      "covariance": [0.0] * 36},
        }
        for topic in self.odom_topics:
            self.publish(topic, odom)
        transforms = [m.transform(p.odom_frame, p.robot_frame, odo.pose, now)]
        if p.fixed_odom_map_tf:
            transforms.insert(0, m.transform(p.map_frame, p.odom_frame, Pose2D(0, 0, 0), now))
        self.publish("/tf", {"transforms": transforms})

    async def _publish_scan(self) -> None:
        began = time.monotonic()
        now = self.bus.clock()  # like the real node: the time the scan request started
        scan = await self.robot.sensors.get_laser_scan()
        scan_time = time.monotonic() - began
        msg = m.laser_scan(scan, self.params.laser_frame, self.params.angle_compensate,
                           scan_time, now)
        if msg is None:
            return
        for topic in self.scan_topics:
            self.publish(topic, msg)
        self.publish("/tf", {"transforms": [
            m.transform(self.params.map_frame, self.params.laser_frame, scan.pose, now)
        ]})

    async def _update_map(self) -> None:
        b = self.robot
        if self.map.resolution is None:
            probe = await b.maps.get_map(Rect(-0.5, -0.5, 1.0, 1.0), MapKind.EXPLORERMAP)
            self.map.reset(probe.resolution)
            self._sync_requested = True
        known = await b.maps.get_known_area(MapKind.EXPLORERMAP)
        if self._sync_requested:
            if known.is_empty:  # cleared: publish unknown cells instead of the old map
                self.map.forget()
                return
            self.map.clear()
            size = max(16.0, self.params.map_sync_once_get_max_wh)
            for tile in tiles(known, size):
                region = await b.maps.get_map(tile, MapKind.EXPLORERMAP)
                if not self.map.merge(region):
                    self.map.resolution = None
                    return
            self._sync_requested = False
            return
        if known.is_empty:
            self._sync_requested = True
            return
        pose = self._last_pose or await b.localization.get_pose()
        half = max(2.0, self.params.map_update_near_robot_half_wh)
        area = window(known, pose.x, pose.y, half)
        if area is None:
            return
        region = await b.maps.get_map(area, MapKind.EXPLORERMAP)
        if not self.map.merge(region):
            self.map.resolution = None

    async def _publish_map(self) -> None:
        if self.map.resolution is None or self.map.empty:
            return
        data, ox, oy = self.map.occupancy()
        h, w = self.map.cells.shape
        now = self.bus.clock()
        info = {
            "map_load_time": m.stamp(now),
            "resolution": self.map.resolution,
            "width": w,
            "height": h,
            "origin": m.pose(Pose2D(ox, oy, 0.0)),
        }
        self.publish(self.topic_map, {"header": m.header(self.params.map_frame, now),
                                      "info": info, "data": data})
        self.publish(self.topic_map_info, info)

    async def _publish_sensors_info(self) -> None:
        sensors = self._sensors = await self.robot.sensors.get_sensors_info()
        signature = tuple((s.id, int(s.sensor_type), int(s.impact_type), s.install_pose)
                          for s in sensors)
        if signature != self._sensor_signature:  # the real node publishes on change only
            self._sensor_signature = signature
            self.publish(self.topic_sensors_info,
                         {"sensors_info": [m.sensor_info(s) for s in sensors]})

    async def _publish_sensor_values(self) -> None:
        # the sensor list comes from the info worker (every 7 s), as in the real node
        sensors = self._sensors or await self.robot.sensors.get_sensors_info()
        values = await self.robot.sensors.get_sensor_values()
        data = [m.sensor_value(s, values[s.id]) for s in sensors if s.id in values]
        self.publish(self.topic_sensors_values, {"values_data": data})

    async def _publish_path(self) -> None:
        points = await self.robot.motion.get_remaining_path()
        frame = self.params.map_frame
        zero = {"secs": 0, "nsecs": 0}
        poses = [{"header": {"seq": 0, "stamp": zero, "frame_id": frame},
                  "pose": m.pose(Pose2D(pt.x, pt.y, 0.0))} for pt in points]
        self.publish(self.topic_path, {"header": {"seq": 0, "stamp": zero, "frame_id": frame},
                                       "poses": poses})

    async def _publish_basic_state(self) -> None:
        b = self.robot
        power = await b.power.get_power_status()
        self.publish(self.topic_state, {
            "is_map_building_enabled": await b.maps.get_map_update(MapKind.EXPLORERMAP),
            "is_localization_enabled": await b.localization.get_localization_enabled(),
            "localization_quality": int(await b.localization.get_localization_quality()),
            "board_temperature": int(await b.power.get_board_temperature()),
            "battery_percentage": int(power.battery_percentage),
            "is_dc_in": bool(power.is_dc_in),
            "is_charging": bool(power.is_charging),
        })

    async def _publish_lines(self, usage: ArtifactUsage) -> None:
        lines = await self.robot.maps.get_lines(usage)
        topic = self.topic_walls if usage == ArtifactUsage.VIRTUAL_WALL else self.topic_tracks
        self.publish(topic, {"lines": [m.line(ln) for ln in lines]})

    # ------------------------------------------------------------------ requests
    def _run(self, message: Message, what: str, call: Callable[[], Awaitable[Any]]) -> None:
        """Carry a validated request out; robot failures go back to the publishing client.

        A motion request starts an action that may fail much later (no path, stuck, ...);
        the real node says nothing then, we watch the action and tell the requester why.
        """

        async def carry_out() -> None:
            result = await call()
            if isinstance(result, ActionInfo):
                await self._watch_action(message.reply, what, result)
            elif result is False:
                message.reply.fail(f"{what}: the robot refused the request")

        require_robot(self.link, what)
        self.spawn(answer(message.reply, what, carry_out()))

    async def _watch_action(self, reply: Reply, what: str, action: ActionInfo) -> None:
        final = await follow(self.robot.motion, action)
        if final is None:  # replaced by a newer action, or forgotten by the robot
            return
        action = final
        if action.result == ActionResult.SUCCESS:
            reply.ok(f"{what}: done")
        elif action.result == ActionResult.ABORTED:  # cancelled or superseded: not an error
            reply.info(f"{what}: {action.reason or 'cancelled'}")
        else:
            why = action.reason or action.result.name.lower()
            reply.fail(f"{what} failed: {why}")

    def _on_cmd_vel(self, message: Message) -> None:
        t = message.msg
        require_finite("linear.x", t["linear"]["x"])
        require_finite("angular.z", t["angular"]["z"])
        self._run(message, "cmd_vel",
                  lambda: self.robot.motion.set_velocity(t["linear"]["x"], t["angular"]["z"]))

    def _on_goal(self, message: Message) -> None:
        p = message.msg["pose"]
        target = _point(p["position"], "pose.position")
        yaw = _quaternion_yaw(p["orientation"], "pose.orientation")
        self._run(message, "move_base_simple/goal", lambda: self.robot.motion.move_to(
            [target], MoveOptions(flags=GOAL_FLAGS), yaw))

    def _on_sync_map(self, message: Message) -> None:
        self._sync_requested = True

    def _on_set_pose(self, message: Message) -> None:
        msg = message.msg
        _point(msg["position"], "position")
        pose = Pose2D(msg["position"]["x"], msg["position"]["y"],
                      _quaternion_yaw(msg["orientation"], "orientation"))

        async def set_pose() -> None:
            """Forced as the SDK does, but the publisher learns whether the robot agrees."""
            await self.robot.localization.set_pose(pose)
            quality = await settled_quality(self.robot.localization)
            if quality >= GOOD_QUALITY:
                message.reply.ok(f"set_pose: localized (quality {quality})")
            else:
                message.reply.warn(f"set_pose: the pose was set but localization has not "
                                   f"converged (quality {quality} < {GOOD_QUALITY}); use "
                                   "/set_initialpose or recover_localization")

        self._run(message, "set_pose", set_pose)

    def _on_recover(self, message: Message) -> None:
        msg = message.msg
        a = msg["area"]
        require_finite("area", a["x"], a["y"], a["w"], a["h"])
        area = Rect(a["x"], a["y"], a["w"], a["h"])
        opts = msg["options"]
        max_time = opts["max_time_ms"]["value"] if opts["max_time_ms"]["is_valid"] else None
        if max_time is not None and max_time <= 0:
            raise RequestRejected("field 'options.max_time_ms.value' must be positive")
        movement = None
        if opts["mvmt_type"]["is_valid"]:
            movement = _enum("options.mvmt_type.value.type", opts["mvmt_type"]["value"]["type"],
                             LocalizationMovement)
        localization = self.robot.localization
        self._run(message, "recover_localization", lambda: localization.recover_localization(
            None if area.is_empty else area, max_time, movement))

    def _on_clear_map(self, message: Message) -> None:
        kind = _enum("kind.kind", message.msg["kind"]["kind"], MapKind)

        async def clear() -> None:
            await self.robot.maps.clear_map(kind)
            self._sync_requested = True

        self._run(message, "clear_map", clear)

    def _on_set_map_update(self, message: Message) -> None:
        msg = message.msg
        kind = _enum("kind.kind", msg["kind"]["kind"], MapKind)
        self._run(message, "set_map_update",
                  lambda: self.robot.maps.set_map_update(bool(msg["enabled"]), kind))

    def _on_set_loc(self, message: Message) -> None:
        enabled = bool(message.msg["enabled"])
        self._run(message, "set_map_localization",
                  lambda: self.robot.localization.set_localization_enabled(enabled))

    def _on_move_by_direction(self, message: Message) -> None:
        msg = message.msg
        direction = _enum("direction.direction", msg["direction"]["direction"], ActionDirection)
        opts = _move_options(msg["options"])
        self._run(message, "move_by_direction",
                  lambda: self.robot.motion.move_by_direction(direction, opts))

    def _on_move_by_theta(self, message: Message) -> None:
        msg = message.msg
        require_finite("theta", msg["theta"])
        opts = _move_options(msg["options"])
        self._run(message, "move_by_theta",
                  lambda: self.robot.motion.move_by_theta(float(msg["theta"]), opts))

    def _on_move_to(self, message: Message) -> None:
        msg = message.msg
        target = _point(msg["location"], "location")
        require_finite("yaw", msg["yaw"])
        opts = _move_options(msg["options"])
        self._run(message, "move_to",
                  lambda: self.robot.motion.move_to([target], opts, float(msg["yaw"])))

    def _on_move_to_locations(self, message: Message) -> None:
        msg = message.msg
        if not msg["locations"]:
            raise RequestRejected("field 'locations' must not be empty")
        targets = [_point(p, f"locations[{i}]") for i, p in enumerate(msg["locations"])]
        require_finite("yaw", msg["yaw"])
        opts = _move_options(msg["options"])
        self._run(message, "move_to_locations",
                  lambda: self.robot.motion.move_to(targets, opts, float(msg["yaw"])))

    def _on_rotate_to(self, message: Message) -> None:
        msg = message.msg
        yaw = _quaternion_yaw(msg["orientation"], "orientation")
        opts = _move_options(msg["options"])
        self._run(message, "rotate_to", lambda: self.robot.motion.rotate_to(yaw, opts))

    def _on_rotate(self, message: Message) -> None:
        msg = message.msg
        angle = _quaternion_yaw(msg["rotation"], "rotation")
        opts = _move_options(msg["options"])
        self._run(message, "rotate", lambda: self.robot.motion.rotate(angle, opts))

    def _on_go_home(self, message: Message) -> None:
        self._run(message, "go_home", self.robot.motion.go_home)

    def _on_cancel(self, message: Message) -> None:
        async def cancel() -> None:
            stopped = await self.robot.motion.cancel_action()
            what = "nothing to cancel" if stopped is None else \
                f"cancelled {stopped.action_name.removeprefix(ACTION_PREFIX)}"
            message.reply.ok(f"cancel_action: {what}")

        self._run(message, "cancel_action", cancel)

    @staticmethod
    def _usage(msg: dict) -> ArtifactUsage:
        return _enum("usage.usage", msg["usage"]["usage"], ArtifactUsage)

    def _on_add_line(self, message: Message) -> None:
        usage, ln = self._usage(message.msg), _line(message.msg["line"], "line")
        self._run(message, "add_line", lambda: self.robot.maps.add_lines(usage, [ln]))

    def _on_add_lines(self, message: Message) -> None:
        usage = self._usage(message.msg)
        lines = [_line(x, f"lines[{i}]") for i, x in enumerate(message.msg["lines"])]
        self._run(message, "add_lines", lambda: self.robot.maps.add_lines(usage, lines))

    def _on_remove_line(self, message: Message) -> None:
        usage, line_id = self._usage(message.msg), int(message.msg["id"])

        async def remove() -> bool:
            if not await self.robot.maps.remove_line(usage, line_id):
                raise BackendError(f"no {usage.name.lower()} with id {line_id}")
            return True

        self._run(message, "remove_line", remove)

    def _on_clear_lines(self, message: Message) -> None:
        usage = self._usage(message.msg)
        self._run(message, "clear_lines", lambda: self.robot.maps.clear_lines(usage))

    def _on_move_line(self, message: Message) -> None:
        usage, ln = self._usage(message.msg), _line(message.msg["line"], "line")
        self._run(message, "move_line", lambda: self._move_lines(usage, [ln]))

    def _on_move_lines(self, message: Message) -> None:
        usage = self._usage(message.msg)
        lines = [_line(x, f"lines[{i}]") for i, x in enumerate(message.msg["lines"])]
        self._run(message, "move_lines", lambda: self._move_lines(usage, lines))

    async def _move_lines(self, usage: ArtifactUsage, lines: list[Line]) -> bool:
        if not await self.robot.maps.move_lines(usage, lines):
            ids = ", ".join(str(ln.id) for ln in lines)
            raise BackendError(f"no {usage.name.lower()} with id(s) {ids}")
        return True

    # ------------------------------------------------------------------ services
    async def _sync_get_stcm(self, request: dict) -> dict:
        try:
            return {"raw_stcm": await self.robot.maps.get_composite_map()}
        except BackendError as exc:
            raise ServiceError(f"sync_get_stcm: {exc}") from None

    async def _sync_set_stcm(self, request: dict) -> dict:
        """The real node's steps, made safe: the map is checked completely first (a refused
        map changes nothing); then cancel, stop localization and mapping, load the composite
        map at the given pose (it replaces the old one, so no separate clear), localize again,
        resync the map copy. If the robot refuses the load, localization and mapping are put
        back as they were."""
        b = self.robot
        data = bytes(request["raw_stcm"])
        if not data:
            raise ServiceError("sync_set_stcm: field 'raw_stcm' is empty")
        pose = m.pose2d(request["robot_pose"])
        try:
            await b.maps.check_composite_map(data)
            localizing = await b.localization.get_localization_enabled()
            mapping = await b.maps.get_map_update(MapKind.EXPLORERMAP)
            await b.motion.cancel_action()
            await b.localization.set_localization_enabled(False)
            await b.maps.set_map_update(False, MapKind.EXPLORERMAP)
            try:
                await b.maps.set_composite_map(data, pose)
            except BackendError:
                await b.maps.set_map_update(mapping, MapKind.EXPLORERMAP)
                await b.localization.set_localization_enabled(localizing)
                raise
            await b.localization.set_localization_enabled(True)
        except BackendError as exc:
            raise ServiceError(f"sync_set_stcm: {exc}") from None
        self._sync_requested = True
        return {}

"""The Slamware node's publishers: like the real node's workers, each with its own period
(≤ 0 disables it): pose and odometry, scans, sensors, the remaining path, the basic state,
virtual walls and tracks, and the device info once the robot connects."""

from __future__ import annotations

import logging
import time
from collections.abc import Awaitable, Callable

from ...robot.backend import BackendError
from ...robot.capabilities import Robot
from ...robot.model import ArtifactUsage, MapKind, Pose2D
from ..base import RobotNode
from ..ground import messages as m
from ..ground.names import MAP_TOPIC, TF
from ..ground.pacing import KEEP_ALIVE, Pace
from ..ground.slamware_params import SlamwareParams
from .map_copy import MapCopy
from .topics import SlamwareTopics

log = logging.getLogger(__name__)

LINES_IDLE = 5.0
"""Seconds between reads of the virtual walls and tracks while nobody reads them (latched)."""


class Publishers:
    """The robot's state on the node's topics and on ``/tf``."""

    def __init__(self, node: RobotNode, robot: Robot, params: SlamwareParams,
                 topics: SlamwareTopics, map_copy: MapCopy):
        self.node, self.robot, self.params, self.topics = node, robot, params, topics
        self.map_copy = map_copy
        self._sensor_signature: tuple | None = None
        self._sensors: list = []  # the robot's sensors, refreshed by the info worker
        self._was_connected = False

    def start(self) -> None:
        """One worker per publisher. Those that fetch often run at their period only while
        someone reads their topics (a client, the recorder, another process, a node that
        needs them), at the black box's period when only it keeps them, and every
        ``KEEP_ALIVE`` seconds otherwise; the basic state (battery, localization: the
        incidents), the sensor list and the connection watch keep their own periods."""
        p, copy, t, node = self.params, self.map_copy, self.topics, self.node
        maps = (t.map, t.map_info, MAP_TOPIC)
        paced: list[tuple[float, Callable[[], Awaitable[None]], tuple[str, ...], float]] = [
            (p.robot_pose_pub_period, self._publish_pose, (*t.odom, TF), KEEP_ALIVE),
            (p.scan_pub_period, self._publish_scan, (*t.scan, TF), KEEP_ALIVE),
            (p.map_update_period, copy.update, maps, KEEP_ALIVE),
            (p.map_pub_period, copy.publish, maps, KEEP_ALIVE),
            (p.basic_sensors_values_pub_period, self._publish_sensor_values,
             (t.sensors_values,), KEEP_ALIVE),
            (p.path_pub_period, self._publish_path, (t.path,), KEEP_ALIVE),
            (p.virtual_walls_pub_period,
             lambda: self._publish_lines(ArtifactUsage.VIRTUAL_WALL), (t.walls,), LINES_IDLE),
            (p.virtual_tracks_pub_period,
             lambda: self._publish_lines(ArtifactUsage.VIRTUAL_TRACK), (t.tracks,), LINES_IDLE),
        ]
        node.every(0.1, self._watch_connection, needs_robot=False)  # while away, too
        for period, work in ((p.basic_sensors_info_update_period, self._publish_sensors_info),
                             (p.robot_basic_state_pub_period, self._publish_basic_state)):
            if period > 0:
                node.every(period, work)
        for period, work, topics, idle in paced:
            if period > 0:
                node.every(period, work, pace=Pace(node.bus.demand, topics, period, idle))

    async def _watch_connection(self) -> None:
        connected = self.node.link.connected
        robot = _robot_words(self.node.name)
        if connected and not self._was_connected:
            log.info("%s connected", robot)
            self.map_copy.forget_robot()
            self._sensors = []  # a (re)connected robot may have other sensors
            try:
                info = await self.robot.sensors.get_device_info()
                self.node.publish(self.topics.device, m.device_info(info))
            except BackendError as exc:
                log.warning("device info: %s", exc)
                return  # try again on the next tick
        elif not connected and self._was_connected:
            log.warning("%s disconnected; retrying every %d ms", robot, self.params.reconn_wait_ms)
        self._was_connected = connected

    async def _publish_pose(self) -> None:
        odo = await self.robot.sensors.get_odometry()
        p = self.params
        self.map_copy.last_pose = odo.pose
        now = self.node.bus.clock()
        odom = {
            "header": m.header(p.odom_frame, now),
            "child_frame_id": p.robot_frame,
            "pose": {"pose": m.pose(odo.pose), "covariance": [0.0] * 36},
            "twist": {"twist": {"linear": {"x": odo.twist.vx, "y": odo.twist.vy, "z": 0.0},
                                "angular": {"x": 0.0, "y": 0.0, "z": odo.twist.omega}},
                      "covariance": [0.0] * 36},
        }
        for topic in self.topics.odom:
            self.node.publish(topic, odom)
        transforms = [m.transform(p.odom_frame, p.robot_frame, odo.pose, now)]
        if p.fixed_odom_map_tf:
            transforms.insert(0, m.transform(p.map_frame, p.odom_frame, Pose2D(0, 0, 0), now))
        self.node.publish(TF, {"transforms": transforms})

    async def _publish_scan(self) -> None:
        began = time.monotonic()
        now = self.node.bus.clock()  # like the real node: the time the scan request started
        scan = await self.robot.sensors.get_laser_scan()
        scan_time = time.monotonic() - began
        msg = m.laser_scan(scan, self.params.laser_frame, self.params.angle_compensate,
                           scan_time, now)
        if msg is None:
            return
        for topic in self.topics.scan:
            self.node.publish(topic, msg)
        self.node.publish(TF, {"transforms": [
            m.transform(self.params.map_frame, self.params.laser_frame, scan.pose, now)
        ]})

    async def _publish_sensors_info(self) -> None:
        sensors = self._sensors = await self.robot.sensors.get_sensors_info()
        signature = tuple((s.id, int(s.sensor_type), int(s.impact_type), s.install_pose)
                          for s in sensors)
        if signature != self._sensor_signature:  # the real node publishes on change only
            self._sensor_signature = signature
            self.node.publish(self.topics.sensors_info,
                              {"sensors_info": [m.sensor_info(s) for s in sensors]})

    async def _publish_sensor_values(self) -> None:
        # the sensor list comes from the info worker (every 7 s), as in the real node
        sensors = self._sensors or await self.robot.sensors.get_sensors_info()
        values = await self.robot.sensors.get_sensor_values()
        data = [m.sensor_value(s, values[s.id]) for s in sensors if s.id in values]
        self.node.publish(self.topics.sensors_values, {"values_data": data})

    async def _publish_path(self) -> None:
        points = await self.robot.motion.get_remaining_path()
        frame = self.params.map_frame
        zero = {"secs": 0, "nsecs": 0}
        poses = [{"header": {"seq": 0, "stamp": zero, "frame_id": frame},
                  "pose": m.pose(Pose2D(pt.x, pt.y, 0.0))} for pt in points]
        self.node.publish(self.topics.path, {
            "header": {"seq": 0, "stamp": zero, "frame_id": frame}, "poses": poses})

    async def _publish_basic_state(self) -> None:
        b = self.robot
        power = await b.power.get_power_status()
        self.node.publish(self.topics.state, {
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
        topic = self.topics.walls if usage == ArtifactUsage.VIRTUAL_WALL else self.topics.tracks
        self.node.publish(topic, {"lines": [m.line(ln) for ln in lines]})


def _robot_words(node: str) -> str:
    """"robot alpha" for a fleet robot's node (/alpha/slamware_ros_sdk_server_node), "robot"
    alone on a single-robot server: each robot's connection is logged once, by its name."""
    robot = node.rsplit("/", 1)[0].strip("/")
    return f"robot {robot}" if robot else "robot"

"""Locomotion and control mode services, ``robot_state`` and the odometry topics.

* ``stand_up`` / ``sit_down`` (std_srvs/Trigger, "Trigger: started"): the locomotion state
  machine of :mod:`hitrobot_server.robot.locomotion`; motion is refused while sitting.
* ``set_listen`` (hitrobot_msgs/SetListen): the control mode, reported as ``joy_listen_type``.
* ``robot_state`` (hitrobot_msgs/RobotState, 20 Hz): the drive motors as CiA402 actuators
  (``left_wheel``, ``right_wheel``), base pose and velocities, battery, body temperature,
  locomotion state and joy source. Published while the robot is offline too (actuators 99
  ECAT_CONN_ERROR, state COMM_DISABLED, the last known pose).
* ``/Odometry`` (nav_msgs/Odometry, 20 Hz): the raw odometry, ``odom`` → ``base_link``.
* ``/{map_name}/{robot_id}/Odometry`` (nav_msgs/Odometry, 20 Hz): the same in the map frame
  (``map`` → ``base_link``; identical numbers since map→odom is the identity here).
  ``map_name`` is the loaded map's name (``map`` until one is loaded; whitespace becomes
  ``_``), ``robot_id`` the parameter ``/robot_id`` (default ``robot_0``, settable through
  rosapi); the topic follows both.

The battery is modelled as a 7S lithium-ion pack (24 V nominal, 21.0-29.4 V): voltage from the
state of charge minus the sag of the current drawn; current = electronics + the drive's
mechanical power, negative while charging. Wheel speeds, angles and torques are derived from
the body velocity with the drive geometry below.
"""

from __future__ import annotations

import logging
import math
import re
import time

from ..bus.core import Bus
from ..bus.errors import BusError
from ..robot.backend import Link, NotConnectedError, PowerBackend, SensorBackend
from ..robot.locomotion import ListenError, Locomotion, parse_listen
from ..robot.model import Odometry, Pose2D, Twist2D
from .base import RobotNode
from .ground import messages as m
from .ground.loadedmap import LoadedMap
from .ground.pacing import Pace
from .ground.requests import NOT_CONNECTED
from .options import NodeOptions

log = logging.getLogger(__name__)

PKG = "hitrobot_msgs"
STATE_TOPIC = "/robot_state"
ODOM_TOPIC = "/Odometry"
ROBOT_ID_PARAM = "/robot_id"
DEFAULT_ROBOT_ID = "robot_0"
STATE_PERIOD = 0.05
"""Seconds between ``robot_state`` and odometry messages (20 Hz)."""
SLOW_PERIOD = 1.0
"""Seconds between looks at the battery and the board temperature."""

WHEEL_RADIUS = 0.08  # m
WHEEL_TRACK = 0.36  # m between the wheels
ROBOT_MASS = 40.0  # kg
ROLLING = 0.015  # rolling resistance coefficient
CELLS = 7
MIN_VOLTAGE, MAX_VOLTAGE = 3.0 * CELLS, 4.2 * CELLS
INTERNAL_RESISTANCE = 0.08  # ohm
IDLE_CURRENT = 1.2  # A, electronics and sensors
MOTORS_CURRENT = 0.4  # A, drives powered
DRIVE_EFFICIENCY = 0.75
CHARGE_CURRENT = 4.0  # A into the pack while charging
OPERATION_ENABLED, READY_TO_SWITCH_ON, ECAT_CONN_ERROR = 39, 33, 99
WHEELS = ("left_wheel", "right_wheel")


def wheel_speeds(vx: float, omega: float) -> tuple[float, float]:
    """Left and right wheel speeds in rad/s of a differential drive."""
    half = WHEEL_TRACK / 2.0
    return (vx - omega * half) / WHEEL_RADIUS, (vx + omega * half) / WHEEL_RADIUS


def wheel_effort(speed: float, accel: float) -> float:
    """Torque in Nm one wheel needs: half the robot's inertia plus rolling resistance."""
    force = ROBOT_MASS / 2.0 * accel * WHEEL_RADIUS
    if abs(speed) > 1e-6:
        force += math.copysign(ROLLING * ROBOT_MASS * 9.81 / 2.0, speed)
    return force * WHEEL_RADIUS


def pack_voltage(percentage: float, current: float) -> float:
    soc = min(max(percentage, 0.0), 100.0) / 100.0
    return MIN_VOLTAGE + (MAX_VOLTAGE - MIN_VOLTAGE) * soc - current * INTERNAL_RESISTANCE


def pack_current(mech_power: float, motors_on: bool, charging: bool) -> float:
    if charging:
        return -CHARGE_CURRENT
    nominal = (MIN_VOLTAGE + MAX_VOLTAGE) / 2.0
    return (IDLE_CURRENT + (MOTORS_CURRENT if motors_on else 0.0)
            + mech_power / DRIVE_EFFICIENCY / nominal)


def topic_part(name: str) -> str:
    """A map name or robot id as one topic name component (whitespace and '/' become '_')."""
    return re.sub(r"[\s/]+", "_", name.strip()) or "_"


class LocomotionNode(RobotNode):
    """stand_up, sit_down, set_listen, robot_state, /Odometry and the map-frame odometry."""

    GLOBAL_NAMES = ("/locomotion", STATE_TOPIC, ODOM_TOPIC, ROBOT_ID_PARAM, "/stand_up",
                    "/sit_down", "/set_listen")

    def __init__(self, bus: Bus, link: Link, locomotion: Locomotion, sensors: SensorBackend,
                 power: PowerBackend, settings: NodeOptions, loaded_map: LoadedMap):
        super().__init__(bus, "/locomotion", link)
        self.locomotion = locomotion
        self.sensors = sensors
        self.power = power
        self.params = settings.slamware
        self.loaded_map = loaded_map  # the map-files node's: names the map-frame odometry
        self.map_topic: str | None = None
        self._refused: str | None = None
        self.odom: Odometry | None = None
        self.percentage = 100.0
        self.charging = False
        self.temperature = 35.0
        self.wheel_pos = [0.0, 0.0]
        self.wheel_vel = [0.0, 0.0]
        self.effort = [0.0, 0.0]
        self._last = time.monotonic()
        # the odometry is fetched at full rate only while the state or an odometry is read
        self._pace = Pace(self.bus.demand, (STATE_TOPIC, ODOM_TOPIC), STATE_PERIOD)
        if not bus.params.has(ROBOT_ID_PARAM):
            bus.params.set(ROBOT_ID_PARAM, DEFAULT_ROBOT_ID)
        self.advertise(STATE_TOPIC, f"{PKG}/RobotState")
        self.advertise(ODOM_TOPIC, "nav_msgs/Odometry")
        self.service("/stand_up", "std_srvs/Trigger", self._stand_up)
        self.service("/sit_down", "std_srvs/Trigger", self._sit_down)
        self.service("/set_listen", f"{PKG}/SetListen", self._set_listen)

    async def start(self) -> None:
        self.every(SLOW_PERIOD, self._slow,  # the battery and temperature of /robot_state
                   pace=Pace(self.bus.demand, (STATE_TOPIC,), SLOW_PERIOD))
        self.every(STATE_PERIOD, self._tick, needs_robot=False, pace=self._pace)

    # ------------------------------------------------------------------ services
    async def _stand_up(self, request: dict) -> dict:
        if not self.link.connected:
            return {"success": False, "message": NOT_CONNECTED}
        await self.locomotion.stand_up()
        return {"success": True, "message": "Trigger: started"}

    async def _sit_down(self, request: dict) -> dict:
        if not self.link.connected:
            return {"success": False, "message": NOT_CONNECTED}
        await self.locomotion.sit_down()
        return {"success": True, "message": "Trigger: started"}

    async def _set_listen(self, request: dict) -> dict:
        try:
            parsed = parse_listen(request["data"])
        except ListenError as exc:
            return {"success": False, "message": str(exc)}
        return {"success": True, "message": self.locomotion.control.apply(parsed)}

    # ------------------------------------------------------------------ topics
    def robot_id(self) -> str:
        try:
            value = self.bus.params.get(ROBOT_ID_PARAM, DEFAULT_ROBOT_ID)
        except Exception:
            value = DEFAULT_ROBOT_ID
        return str(value) if value not in (None, "") else DEFAULT_ROBOT_ID

    def map_odometry_topic(self) -> str:
        return f"/{topic_part(self.loaded_map.frame)}/{topic_part(self.robot_id())}/Odometry"

    async def _slow(self) -> None:
        power = await self.power.get_power_status()
        self.percentage, self.charging = float(power.battery_percentage), power.is_charging
        self.temperature = float(await self.power.get_board_temperature())

    async def _tick(self) -> None:
        now = time.monotonic()
        # a slow tick (nobody reads) integrates its whole time; a stall at most half a second
        dt, self._last = min(now - self._last, max(0.5, 2 * self._pace.period())), now
        connected = self.link.connected
        if connected:
            try:
                odo = await self.sensors.get_odometry()
            except NotConnectedError:
                connected = False
            else:
                self._integrate(odo.twist, dt)
                self.odom = odo
                self._publish_odometry(odo)
        if not connected:
            self.wheel_vel, self.effort = [0.0, 0.0], [0.0, 0.0]
        self.publish(STATE_TOPIC, self._state(connected))

    def _integrate(self, twist: Twist2D, dt: float) -> None:
        speeds = wheel_speeds(twist.vx, twist.omega)
        for i, w in enumerate(speeds):
            accel = (w - self.wheel_vel[i]) * WHEEL_RADIUS / dt if dt > 0 else 0.0
            self.effort[i] = wheel_effort(w, accel)
            self.wheel_pos[i] += w * dt
            self.wheel_vel[i] = w

    def _state(self, connected: bool) -> dict:
        b = self.locomotion
        enabled = connected and b.motors_enabled
        status = (ECAT_CONN_ERROR if not connected
                  else OPERATION_ENABLED if enabled else READY_TO_SWITCH_ON)
        mech = sum(abs(t * w) for t, w in zip(self.effort, self.wheel_vel, strict=True))
        if connected:
            current = pack_current(mech, enabled, self.charging)
            voltage = pack_voltage(self.percentage, current)
        else:
            current = voltage = 0.0
        actuators = [{
            "name": name, "position": self.wheel_pos[i], "velocity": self.wheel_vel[i],
            "effort": self.effort[i], "status": status,
            "temperature": self.temperature + (3.0 + 0.5 * abs(self.effort[i]) if enabled
                                               else 0.0),
        } for i, name in enumerate(WHEELS)]
        odo = self.odom if connected and self.odom is not None else None
        pose = self.odom.pose if self.odom is not None else Pose2D(0.0, 0.0, 0.0)
        twist = odo.twist if odo is not None else Twist2D(0.0, 0.0, 0.0)
        q = m.quaternion(pose.yaw)
        return {
            "actuator_states": actuators,
            "base_pos": [pose.x, pose.y, 0.0],
            "base_quat": [q["x"], q["y"], q["z"], q["w"]],
            "base_lin_vel": [twist.vx, twist.vy, 0.0],
            "base_ang_vel": [0.0, 0.0, twist.omega],
            "voltage": voltage, "current": current,
            "max_voltage": MAX_VOLTAGE, "min_voltage": MIN_VOLTAGE,
            "body_temperature": self.temperature,
            "state": int(b.state), "joy_listen_type": int(b.control.listen_type),
        }

    def _odometry(self, odo: Odometry, frame: str) -> dict:
        t = odo.twist
        return {
            "header": m.header(frame, self.bus.clock()),
            "child_frame_id": self.params.robot_frame,
            "pose": {"pose": m.pose(odo.pose), "covariance": [0.0] * 36},
            "twist": {"twist": {"linear": {"x": t.vx, "y": t.vy, "z": 0.0},
                                "angular": {"x": 0.0, "y": 0.0, "z": t.omega}},
                      "covariance": [0.0] * 36},
        }

    def _publish_odometry(self, odo: Odometry) -> None:
        self.publish(ODOM_TOPIC, self._odometry(odo, self.params.odom_frame))
        topic = self.map_odometry_topic()
        if topic == self._refused:
            return
        if topic != self.map_topic:
            if self.map_topic is not None:
                self.bus.unadvertise(self.map_topic, self)
                self.map_topic = None
            try:
                self.advertise(topic, "nav_msgs/Odometry")
            except BusError as exc:  # e.g. a client holds that name with another type
                log.warning("map odometry topic %s: %s", topic, exc)
                self._refused = topic
                return
            self.map_topic, self._refused = topic, None
            self._pace.follow((STATE_TOPIC, ODOM_TOPIC, topic))
        self.publish(topic, self._odometry(odo, self.params.map_frame))

"""One named robot's state on the site-wide ``/fleet/members`` (``hitrobot_msgs/FleetRobot``,
2 Hz), heard by the site's fleet node here or, over ``--bus zenoh``, on another server."""

from __future__ import annotations

import logging

from ...bus.core import Bus
from ...robot.backend import BackendError
from ...robot.capabilities import Robot
from ...robot.model import HealthLevel, Pose2D
from ..base import RobotNode
from ..ground import messages as m
from ..ground.names import FLEET_MEMBERS
from ..ground.requests import NOT_CONNECTED

log = logging.getLogger(__name__)

PKG = "hitrobot_msgs"
MEMBERS = FLEET_MEMBERS
PERIOD = 0.5  # /fleet/robots and /fleet/members: 2 Hz
OFFLINE_AFTER = 3.0
IDLE, MOVING, CHARGING, ERROR, OFFLINE = "idle", "moving", "charging", "error", "offline"


class FleetMemberNode(RobotNode):
    """One named robot's state on ``/fleet/members`` (2 Hz)."""

    def __init__(self, bus: Bus, robot: Robot, name: str):
        super().__init__(bus, "/fleet_member", robot.link)
        self.motion, self.localization = robot.motion, robot.localization
        self.sensors, self.power, self.maps = robot.sensors, robot.power, robot.maps
        self.robot = name
        self.advertise(MEMBERS, f"{PKG}/FleetRobot")

    async def start(self) -> None:
        self.every(PERIOD, self._publish, needs_robot=False)

    async def _publish(self) -> None:
        self.publish(MEMBERS, await self.state())

    async def state(self) -> dict:
        msg = {"name": self.robot, "pose": m.pose(Pose2D(0, 0, 0)), "state": OFFLINE,
               "battery": 0.0, "task": 0, "message": NOT_CONNECTED, "in_service": True,
               "dock": m.pose(Pose2D(0, 0, 0)), "has_dock": False}
        if not self.link.connected:
            return msg
        try:
            pose, action, power, health = (
                await self.localization.get_pose(), await self.motion.get_current_action(),
                await self.power.get_power_status(), await self.sensors.get_health())
            dock = await self.maps.get_home_pose()
        except BackendError as exc:
            return {**msg, "message": str(exc)}
        msg.update(pose=m.pose(pose), battery=float(power.battery_percentage), message="")
        if dock is not None:
            msg.update(dock=m.pose(dock), has_dock=True)
        errors = [e for e in health.errors if e.level >= HealthLevel.ERROR]
        if errors:
            msg.update(state=ERROR, message=errors[0].message)
        elif action is not None:
            msg.update(state=MOVING, message=action.action_name.rsplit(".", 1)[-1])
        elif power.is_charging:
            msg["state"] = CHARGING
        else:
            msg["state"] = IDLE
        return msg

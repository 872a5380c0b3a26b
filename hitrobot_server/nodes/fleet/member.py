"""One named robot's state on the site-wide ``/fleet/members`` (``hitrobot_msgs/FleetRobot``,
2 Hz), heard by the site's fleet node here or, over ``--bus zenoh``, on another server."""

from __future__ import annotations

import logging
import re

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
WAITING = "waiting"
"""On ``/fleet/robots`` only: stopped before a mutex zone it waits for (the fleet knows it,
the robot reports itself idle)."""


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
            msg.update(state=MOVING, message=action_words(action.action_name))
        elif power.is_charging:
            msg["state"] = CHARGING
        else:
            msg["state"] = IDLE
        return msg


ACTION_WORDS = {"MoveToAction": "go to", "SeriesMoveToAction": "go to", "GoHomeAction": "go home",
                "MoveByAction": "move by", "RotateAction": "rotate", "RotateToAction": "turn",
                "RecoverLocalizationAction": "find its place",
                "VelocityControlAction": "driven by hand"}
"""What the robot does, in the operator's words (the robot names its action's class)."""


def action_words(action_name: str) -> str:
    """``slamtec.agent.actions.SeriesMoveToAction`` → ``go to``; an action not listed, its name
    as words (``SweepSpotAction`` → ``sweep spot``)."""
    name = action_name.rsplit(".", 1)[-1]
    if name in ACTION_WORDS:
        return ACTION_WORDS[name]
    words = re.sub(r"(?<!^)(?=[A-Z])", " ", name.removesuffix("Action")).lower()
    return words or name

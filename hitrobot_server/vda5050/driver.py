"""A vehicle's motion over the bus, through the robot's own actions and services: a node is a
goal of ``/NAME/intelligent_navigate_to_pose``, ``initPosition`` is ``/NAME/set_initialpose``,
``startCharging`` the Slamware node's ``go_home``. The driver knows when it stopped a goal
itself, so a goal ended by anyone else (a console's cancel, another motion) is told apart."""

from __future__ import annotations

import asyncio
import math
from dataclasses import dataclass

from ..bus.core import Bus
from ..bus.namespace import Namespace
from ..bus.services import STATUS_CANCELED, STATUS_SUCCEEDED, GoalHandle
from ..nodes.ground import messages as m
from ..nodes.ground.names import SLAMWARE_NODE
from ..robot.model import Pose2D

NAVIGATE = "/intelligent_navigate_to_pose"
INITIAL_POSE = "/set_initialpose"
GO_HOME = f"{SLAMWARE_NODE}/go_home"
GO_HOME_TYPE = "slamware_ros_sdk/GoHomeRequest"
FREE_NAVIGATION = 2
TAKEN_WORDS = ("supersed", "taken over", "cancel")

ARRIVED, STOPPED, TAKEN, FAILED = "arrived", "stopped", "taken", "failed"


@dataclass(frozen=True)
class Outcome:
    """How one drive to a node ended: ``kind`` one of ARRIVED, STOPPED (by us), TAKEN (by
    someone else: a cancel or another motion), FAILED (no path, blocked); ``reason`` why."""

    kind: str
    reason: str = ""


def navigation_goal(x: float, y: float, theta: float | None, map_frame: str) -> dict:
    """A goal of the intelligent navigation action: free navigation, the final turn only when
    the node gives a ``theta``."""
    return {
        "travel_params": {"speed_mode": {"value": 0}, "gait": {"gait": 0},
                          "obstacle_params": {"disable_body_obstacle_avoidance": False},
                          "ignore_final_yaw": theta is None,
                          "nav_mode": {"value": FREE_NAVIGATION}, "direction_constraint": 0,
                          "path_following_mode": 0, "height": 0},
        "pose": m.pose_stamped(Pose2D(x, y, theta or 0.0), map_frame),
        "should_stop": False,
    }


class Driver:
    """One robot's motion as a VDA 5050 vehicle asks for it."""

    def __init__(self, bus: Bus, robot: str, map_frame: str):
        self.bus, self.map_frame = bus, map_frame
        self.ns = Namespace(robot) if robot else None
        self.goal: GoalHandle | None = None
        self._stopping = False
        self._advertised = False
        self.ended_at = 0.0  # loop time our last goal ended: a robot read before saw it run

    def name(self, name: str) -> str:
        return self.ns.resolve(name) if self.ns else name

    async def go(self, position: dict) -> Outcome:
        """Drive to a node's position; returns when the robot is there or the goal ended."""
        theta = position.get("theta")
        goal = navigation_goal(position["x"], position["y"],
                               theta if theta is not None and math.isfinite(theta) else None,
                               self.map_frame)
        self._stopping = False
        try:
            self.goal, outcome = self.bus.start_goal(self.name(NAVIGATE), goal)
            result = await outcome
        except Exception as exc:
            return Outcome(FAILED, str(exc))
        finally:
            self.goal = None
            self.ended_at = asyncio.get_running_loop().time()
        values = result.values if isinstance(result.values, dict) else {}
        reason = str(values.get("message", result.values if isinstance(result.values, str)
                                else ""))
        if result.status == STATUS_SUCCEEDED:
            return Outcome(ARRIVED, reason)
        if self._stopping:
            return Outcome(STOPPED, reason)
        if result.status == STATUS_CANCELED or any(w in reason.lower() for w in TAKEN_WORDS):
            return Outcome(TAKEN, reason or "cancelled")
        return Outcome(FAILED, reason or "the robot did not get there")

    def stop(self) -> None:
        """Cancel the goal running for us (a pause, a cancelOrder)."""
        if self.goal is not None:
            self._stopping = True
            self.goal.cancel()

    def go_home(self) -> None:
        topic = self.name(GO_HOME)
        if not self._advertised:
            self.bus.advertise(topic, GO_HOME_TYPE, self, "/vda5050")
            self._advertised = True
        self.bus.publish(topic, {})

    async def relocalize(self, x: float, y: float, theta: float) -> tuple[bool, str]:
        """Ask the robot to localize near (x, y, theta); (done, why)."""
        stamped = m.pose_stamped(Pose2D(x, y, theta), self.map_frame)
        request = {"init_pose": {"header": stamped["header"],
                                 "pose": {"pose": stamped["pose"], "covariance": [0.0] * 36}}}
        try:
            reply = await self.bus.call_service(self.name(INITIAL_POSE), request, timeout=30.0)
        except Exception as exc:
            return False, str(exc)
        if not reply.get("result"):
            return False, "the scan did not match the map near that pose"
        return True, "localized"

    def close(self) -> None:
        self.stop()
        if self._advertised:
            self.bus.unadvertise(self.name(GO_HOME), self)

"""The conventional ROS operations of seed §4.3: ``/robot_pose`` and ``/initialpose``.

``/robot_pose`` is what ``robot_pose_publisher`` gives a ROS robot and what nav2d pages subscribe
to (``geometry_msgs/Pose``, the robot in the map frame). ``/initialpose`` is rviz's and nav2d's
"2D Pose Estimate" (``geometry_msgs/PoseWithCovarianceStamped``): the robot is told where it is.

"""

from __future__ import annotations

import logging

from ..bus.core import Bus
from ..bus.topics import Message, RequestRejected
from ..robot.backend import Link, LocalizationBackend
from .base import RobotNode
from .ground import messages as m
from .ground.messages import map_frames, pose2d_of
from .ground.pacing import Pace
from .ground.requests import answer, require_robot

log = logging.getLogger(__name__)

ROBOT_POSE_PERIOD = 0.05
"""Seconds between ``/robot_pose`` messages (20 Hz; nav2d throttles to 10 Hz itself)."""


class ConventionalNode(RobotNode):
    """``/robot_pose`` out, ``/initialpose`` in."""

    GLOBAL_NAMES = ("/robot_pose_publisher", "/robot_pose", "/initialpose", "/conventional")

    def __init__(self, bus: Bus, link: Link, localization: LocalizationBackend,
                 map_frame: str = "/map"):
        super().__init__(bus, "/robot_pose_publisher", link)
        self.localization = localization
        self.frames = map_frames(map_frame)
        self.advertise("/robot_pose", "geometry_msgs/Pose")
        self.subscribe("/initialpose", "geometry_msgs/PoseWithCovarianceStamped",
                       self._on_initialpose)

    async def start(self) -> None:
        self.every(ROBOT_POSE_PERIOD, self._publish_pose,  # at full rate while it is read
                   pace=Pace(self.bus.demand, ("/robot_pose",), ROBOT_POSE_PERIOD))

    async def _publish_pose(self) -> None:
        self.publish("/robot_pose", m.pose(await self.localization.get_pose()))

    def _on_initialpose(self, message: Message) -> None:
        msg = message.msg
        frame = msg["header"]["frame_id"]
        if frame not in self.frames:
            raise RequestRejected(
                f"header.frame_id '{frame}' is not the map frame; give the pose in 'map'")
        pose = pose2d_of(msg["pose"]["pose"], "pose.pose")
        require_robot(self.link, "")  # /initialpose answers are not labelled
        self.spawn(answer(message.reply, "", self.localization.set_pose(pose),
                          failed="set pose failed"))

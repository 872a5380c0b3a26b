"""The conventional ROS operations of seed §4.3: ``/robot_pose`` and ``/initialpose``.

``/robot_pose`` is what ``robot_pose_publisher`` gives a ROS robot and what nav2d pages subscribe
to (``geometry_msgs/Pose``, the robot in the map frame). ``/initialpose`` is rviz's and nav2d's
"2D Pose Estimate" (``geometry_msgs/PoseWithCovarianceStamped``): the robot is told where it is.

:class:`RobotNode` is the small base the robot-facing nodes of this package share: background
workers at a fixed rate that skip their work while the robot is offline, and a clean ``stop``.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any

from ..bus.core import Bus
from ..bus.topics import Message, RequestRejected
from ..robot.backend import BackendError, NotConnectedError, RobotBackend
from ..robot.model import Pose2D
from .base import Node
from .slamware import messages as m

log = logging.getLogger(__name__)

ROBOT_POSE_PERIOD = 0.05
"""Seconds between ``/robot_pose`` messages (20 Hz; nav2d throttles to 10 Hz itself)."""


def map_frames(map_frame: str) -> frozenset[str]:
    """Frame ids that name the map frame: empty (unset), ``map``, ``/map`` and the node's own."""
    bare = map_frame.lstrip("/")
    return frozenset({"", "map", "/map", bare, f"/{bare}"})


def finite(path: str, *values: float) -> None:
    """Refuse NaN and infinities with the offending field's path."""
    if not all(math.isfinite(v) for v in values):
        raise RequestRejected(f"field '{path}' must be a finite number")


def pose2d_of(pose: dict, path: str) -> Pose2D:
    """A validated geometry_msgs/Pose as the robot's planar pose (all-zero quaternion = yaw 0)."""
    p, q = pose["position"], pose["orientation"]
    finite(f"{path}.position", p["x"], p["y"], p["z"])
    finite(f"{path}.orientation", q["x"], q["y"], q["z"], q["w"])
    return Pose2D(float(p["x"]), float(p["y"]), m.yaw_of(q))


class RobotNode(Node):
    """A node backed by the robot: owns background tasks, stopped by :meth:`stop`."""

    def __init__(self, bus: Bus, name: str, backend: RobotBackend | None):
        super().__init__(bus, name)
        self.backend = backend
        self._tasks: set[asyncio.Task] = set()

    @property
    def robot_connected(self) -> bool:
        return self.backend is not None and self.backend.connected

    def spawn(self, coro: Coroutine[Any, Any, Any]) -> asyncio.Task:
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    def every(self, period: float, work: Callable[[], Awaitable[None]],
              needs_robot: bool = True) -> asyncio.Task:
        """Run ``work`` at a fixed rate without drift; ticks are skipped while the robot is
        offline (when ``needs_robot``) and a slow tick never causes a burst."""

        async def loop() -> None:
            clock = asyncio.get_running_loop()
            due = clock.time()
            while True:
                if not needs_robot or self.robot_connected:
                    try:
                        await work()
                    except NotConnectedError:
                        pass
                    except BackendError as exc:
                        log.warning("%s: %s", self.name, exc)
                    except Exception:
                        log.exception("%s: worker failed", self.name)
                due += period
                delay = due - clock.time()
                if delay < 0:
                    due, delay = clock.time(), 0.0
                await asyncio.sleep(delay)

        return self.spawn(loop())

    async def start(self) -> None:
        """Start the node's workers (none by default)."""

    async def stop(self) -> None:
        for task in list(self._tasks):
            task.cancel()
        for task in list(self._tasks):
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self.close()


class ConventionalNode(RobotNode):
    """``/robot_pose`` out, ``/initialpose`` in."""

    def __init__(self, bus: Bus, backend: RobotBackend, map_frame: str = "/map"):
        super().__init__(bus, "/robot_pose_publisher", backend)
        self.backend: RobotBackend = backend
        self.frames = map_frames(map_frame)
        self.advertise("/robot_pose", "geometry_msgs/Pose")
        self.subscribe("/initialpose", "geometry_msgs/PoseWithCovarianceStamped",
                       self._on_initialpose)

    async def start(self) -> None:
        self.every(ROBOT_POSE_PERIOD, self._publish_pose)

    async def _publish_pose(self) -> None:
        self.publish("/robot_pose", m.pose(await self.backend.get_pose()))

    def _on_initialpose(self, message: Message) -> None:
        msg = message.msg
        frame = msg["header"]["frame_id"]
        if frame not in self.frames:
            raise RequestRejected(
                f"header.frame_id '{frame}' is not the map frame; give the pose in 'map'")
        pose = pose2d_of(msg["pose"]["pose"], "pose.pose")
        if not self.backend.connected:
            raise RequestRejected("the robot is not connected")

        async def apply() -> None:
            try:
                await self.backend.set_pose(pose)
            except NotConnectedError:
                message.reject("the robot is not connected")
            except BackendError as exc:
                message.reject(f"set pose failed: {exc}")

        self.spawn(apply())

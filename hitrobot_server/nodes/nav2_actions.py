"""nav2's planner and controller as ROS 2 actions: ``/compute_path_to_pose`` and ``/follow_path``.

Both are served on the bus with :meth:`Node.action`, so clients reach them with the protocol's
``send_action_goal`` / ``cancel_action_goal`` ops (roslibjs ``ROSLIB.Action``, roslibpy's ROS 2
``ActionClient``).

``/compute_path_to_pose`` (``nav2_msgs/action/ComputePathToPose``) plans with the robot's own
planner without moving (:meth:`MotionBackend.compute_path`): from ``start`` when ``use_start``,
else from the robot's pose, to ``goal``. The result ``path`` (``nav_msgs/Path`` in the map
frame) is the planned polyline resampled every :data:`PATH_SPACING` m, each pose facing along
the path, the last one with the goal's orientation; ``planning_time`` is the wall time the
planner took. ``planner_id`` is accepted and ignored (there is one planner). No path → ABORTED
with the reason; so is a goal inside an obstacle whose nearest free spot is farther than
:data:`GOAL_TOLERANCE` (the path would not lead to the goal). Over REST the server plans
itself, on the robot's map, lines and blocked areas (:meth:`MotionBackend.compute_path`).

``/follow_path`` (``nav2_msgs/action/FollowPath``) drives the given path: it is reduced to its
corners (Douglas-Peucker, :data:`SIMPLIFY_TOLERANCE`) and handed to the robot as one
``SeriesMoveTo`` through them (the robot plans each short leg itself, so it still avoids what is
in the way), turning to the last pose's orientation at the end (none when that quaternion is
all zero). Feedback at every look at the robot's action
(:data:`~hitrobot_server.robot.motion.POLL_PERIOD`): ``distance_to_goal`` is the length of the path
still ahead of the robot's projection onto it (never increases), ``speed`` the robot's linear
speed. The result (empty) comes when the last point is reached; cancel stops the robot (status
5); a robot failure or another command replacing the motion → ABORTED with the reason.
``controller_id`` and ``goal_checker_id`` are accepted and ignored.

Shared conventions (also used by :mod:`.intelligent_navigation`): a goal that cannot run at
all (a frame other than the map, NaN, an empty path, the robot offline) ends at once with status
6 and the reason as text (``result`` false); a goal that ran ends with its result message and
``result`` true, status 4, 5 or 6.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time

import numpy as np

from ..bus.core import Bus
from ..bus.services import (
    STATUS_ABORTED,
    STATUS_CANCELED,
    STATUS_SUCCEEDED,
    GoalHandle,
    GoalOutcome,
)
from ..robot.backend import (
    BackendError,
    Link,
    LocalizationBackend,
    MotionBackend,
    NotConnectedError,
    SensorBackend,
)
from ..robot.model import (
    ActionInfo,
    MoveOptionFlag,
    MoveOptions,
    Odometry,
    Point2D,
    Pose2D,
)
from ..robot.motion import drive
from .base import RobotNode
from .ground import messages as m
from .ground.claims import MotionClaims
from .ground.messages import GoalRejected, goal_pose, map_frames, pose_stamped, rejected
from .ground.names import COMPUTE_PATH, FOLLOW_PATH
from .ground.requests import NOT_CONNECTED

log = logging.getLogger(__name__)

PATH_SPACING = 0.05
"""Spacing (m) of the poses of a computed path (the map resolution, as nav2's planners give)."""
SIMPLIFY_TOLERANCE = 0.05
"""How far (m) the corners handed to the robot may cut a followed path."""
GOAL_TOLERANCE = 0.15
"""A planned path must end this close (m) to the goal (the robot's default arrival tolerance);
a goal inside an obstacle is otherwise replaced by a free spot farther away, and that is a
failure, not a path to the goal."""
START_SKIP = 0.15
"""A followed path's first point this close (m) to the robot is where it already is."""


# ------------------------------------------------------------------ message helpers
def duration(seconds: float) -> dict:
    secs = math.floor(seconds)
    return {"secs": int(secs), "nsecs": min(int((seconds - secs) * 1e9), 999_999_999)}


def has_orientation(pose: dict) -> bool:
    q = pose["orientation"]
    return not (q["x"] == q["y"] == q["z"] == q["w"] == 0.0)


def resample(points: list[Point2D], spacing: float = PATH_SPACING) -> list[Point2D]:
    """The polyline through ``points`` with a point at least every ``spacing`` metres (every
    original vertex kept)."""
    if len(points) < 2:
        return list(points)
    out = [points[0]]
    for a, b in zip(points, points[1:], strict=False):
        n = max(1, math.ceil(math.hypot(b.x - a.x, b.y - a.y) / spacing))
        out.extend(Point2D(a.x + (b.x - a.x) * k / n, a.y + (b.y - a.y) * k / n)
                   for k in range(1, n + 1))
    return out


def path_poses(points: list[Point2D], final_yaw: float) -> list[Pose2D]:
    """Poses along ``points``: each facing the next point, the last one ``final_yaw``."""
    poses = []
    for i, p in enumerate(points):
        if i + 1 < len(points):
            q = points[i + 1]
            yaw = math.atan2(q.y - p.y, q.x - p.x)
        else:
            yaw = final_yaw
        poses.append(Pose2D(p.x, p.y, yaw))
    return poses


def simplify(points: np.ndarray, tolerance: float) -> np.ndarray:
    """Douglas-Peucker: the vertices of ``points`` (N×2) needed to stay within ``tolerance``."""
    if len(points) < 3:
        return points
    keep = np.zeros(len(points), dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, len(points) - 1)]
    while stack:
        lo, hi = stack.pop()
        if hi - lo < 2:
            continue
        a, b = points[lo], points[hi]
        ab = b - a
        seg = points[lo + 1:hi] - a
        length = math.hypot(*ab)
        if length < 1e-9:
            dist = np.hypot(seg[:, 0], seg[:, 1])
        else:
            dist = np.abs(ab[0] * seg[:, 1] - ab[1] * seg[:, 0]) / length
        k = int(np.argmax(dist))
        if dist[k] > tolerance:
            mid = lo + 1 + k
            keep[mid] = True
            stack.extend(((lo, mid), (mid, hi)))
    return points[keep]


class PathProgress:
    """Where the robot is along a fixed polyline; the projection only moves forward."""

    def __init__(self, points: np.ndarray):
        self.points = points
        seg = np.hypot(*np.diff(points, axis=0).T) if len(points) > 1 else np.zeros(0)
        self.lengths = seg
        self.after = np.concatenate((np.cumsum(seg[::-1])[::-1], [0.0]))  # length from vertex
        self.segment = 0
        self.t = 0.0

    def remaining(self, x: float, y: float) -> float:
        pts = self.points
        if len(pts) < 2:
            return math.hypot(pts[0, 0] - x, pts[0, 1] - y)
        robot = np.array([x, y])
        best = (math.inf, self.segment, self.t)
        for k in range(self.segment, len(pts) - 1):
            a, b = pts[k], pts[k + 1]
            ab = b - a
            denom = float(ab @ ab)
            t = 0.0 if denom == 0.0 else min(1.0, max(0.0, float((robot - a) @ ab) / denom))
            if k == self.segment:
                t = max(t, self.t)
            d = float(np.hypot(*(a + t * ab - robot)))
            if d < best[0] - 1e-9:
                best = (d, k, t)
        _, self.segment, self.t = best
        k = self.segment
        return float((1.0 - self.t) * self.lengths[k] + self.after[k + 1])


# ------------------------------------------------------------------ the node
class Nav2ActionsNode(RobotNode):
    """Serves ``/compute_path_to_pose`` and ``/follow_path``."""

    GLOBAL_NAMES = ("/nav2_actions", COMPUTE_PATH, FOLLOW_PATH)

    def __init__(self, bus: Bus, link: Link, motion: MotionBackend,
                 localization: LocalizationBackend, sensors: SensorBackend,
                 map_frame: str = "/map", claims: MotionClaims | None = None):
        super().__init__(bus, "/nav2_actions", link)
        self.motion = motion
        self.claims = claims or MotionClaims()  # who took the robot over from a path
        self.localization = localization
        self.sensors = sensors
        self.map_frame = map_frame
        self.frames = map_frames(map_frame)
        self.action(COMPUTE_PATH, "nav2_msgs/action/ComputePathToPose", self._compute_path)
        self.action(FOLLOW_PATH, "nav2_msgs/action/FollowPath", self._follow_path)

    # ---------------------------------------------------------------- compute_path_to_pose
    async def _compute_path(self, handle: GoalHandle) -> GoalOutcome:
        goal = handle.goal
        try:
            target = goal_pose(self.frames, goal["goal"], "goal")
            start = goal_pose(self.frames, goal["start"], "start") if goal["use_start"] else None
            if not self.link.connected:
                raise GoalRejected(NOT_CONNECTED)
        except GoalRejected as exc:
            return rejected(str(exc))
        began = time.perf_counter()
        planning = asyncio.ensure_future(self.motion.compute_path(start, target))
        waiter = asyncio.ensure_future(handle.cancelled.wait())
        try:
            await asyncio.wait({planning, waiter}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            waiter.cancel()
        if not planning.done():
            planning.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await planning
            return GoalOutcome(STATUS_CANCELED, self._path_result([], target.yaw, 0.0), True)
        spent = time.perf_counter() - began
        try:
            points = planning.result()
        except BackendError as exc:
            return GoalOutcome(STATUS_ABORTED, f"compute_path_to_pose: {exc}", False)
        end = points[-1] if points else None
        off = math.inf if end is None else math.hypot(end.x - target.x, end.y - target.y)
        if off > GOAL_TOLERANCE:
            return GoalOutcome(STATUS_ABORTED, (
                f"compute_path_to_pose: target unreachable: ({target.x:.2f}, {target.y:.2f}) "
                f"is inside an obstacle; the nearest free spot is {off:.2f} m away "
                f"(tolerance {GOAL_TOLERANCE:.2f} m)"), False)
        return GoalOutcome(STATUS_SUCCEEDED, self._path_result(points, target.yaw, spent), True)

    def _path_result(self, points: list[Point2D], yaw: float, spent: float) -> dict:
        now = self.bus.clock()
        poses = path_poses(resample(points), yaw)
        return {
            "path": {"header": m.header(self.map_frame, now),
                     "poses": [pose_stamped(p, self.map_frame, now) for p in poses]},
            "planning_time": duration(spent),
        }

    # ---------------------------------------------------------------- follow_path
    async def _follow_path(self, handle: GoalHandle) -> GoalOutcome:
        goal = handle.goal
        try:
            path = goal["path"]
            poses = path["poses"]
            if not poses:
                raise GoalRejected("field 'path.poses' is empty: nothing to follow")
            header_frame = path["header"]["frame_id"]
            planar = []
            for i, stamped in enumerate(poses):
                if header_frame and not stamped["header"]["frame_id"]:
                    stamped = {**stamped, "header": {**stamped["header"],
                                                     "frame_id": header_frame}}
                planar.append(goal_pose(self.frames, stamped, f"path.poses[{i}]"))
            if not self.link.connected:
                raise GoalRejected(NOT_CONNECTED)
            robot = await self.localization.get_pose()
        except GoalRejected as exc:
            return rejected(str(exc))
        except NotConnectedError:
            return rejected(NOT_CONNECTED)
        xy = np.array([(p.x, p.y) for p in planar], dtype=np.float64)
        corners = simplify(xy, SIMPLIFY_TOLERANCE)
        if len(corners) > 1 and math.hypot(corners[0, 0] - robot.x,
                                           corners[0, 1] - robot.y) < START_SKIP:
            corners = corners[1:]
        targets = [Point2D(float(x), float(y)) for x, y in corners]
        last = poses[-1]["pose"]
        flags = MoveOptionFlag.NONE
        if has_orientation(last):
            flags |= MoveOptionFlag.WITH_YAW
        options = MoveOptions(flags=flags)
        progress = PathProgress(xy)

        def on_poll(_action: ActionInfo, odometry: Odometry) -> None:
            handle.feedback({
                "distance_to_goal": progress.remaining(odometry.pose.x, odometry.pose.y),
                "speed": abs(odometry.twist.vx),
            })

        started: list[int] = []

        async def start() -> ActionInfo:
            action = await self.motion.move_to(targets, options, planar[-1].yaw)
            started.append(action.action_id)
            return action

        end = await drive(self.motion, handle.cancelled, start, self.sensors.get_odometry,
                          on_poll)
        if end.kind == "succeeded":
            handle.feedback({"distance_to_goal": 0.0, "speed": 0.0})
            return GoalOutcome(STATUS_SUCCEEDED, {"result": {}}, True)
        if end.kind == "canceled":
            return GoalOutcome(STATUS_CANCELED, {"result": {}}, True)
        if end.kind == "preempted" and (by := self.claims.taken_by(started[-1])):
            return GoalOutcome(STATUS_ABORTED, f"follow_path: taken over by {by}", False)
        return GoalOutcome(STATUS_ABORTED, f"follow_path: {end.reason}", False)

"""The daystar navigation interface: ``/intelligent_navigate_to_pose`` and ``/set_initialpose``.

``/intelligent_navigate_to_pose`` (``daystar_navigation_msgs/action/IntelligentNavitateToPose``,
the vendor's spelling; also served as ``/nav/intelligent_navigate_to_pose``, the name the
vendor's test command uses, and ``/intelligent_navigat_to_pose``, the seed table's) drives
the robot to ``pose`` (map frame) with its travel parameters applied where a wheeled robot
can:

* ``speed_mode.value`` → the move's speed ratio: 2 low (0.3), 1 medium (0.6), 3 high (1.0);
  0 = the robot's default;
* ``ignore_final_yaw`` → no final turn (no ``WITH_YAW``); otherwise the robot ends facing the
  pose's orientation;
* navigation mode, from ``nav_mode.value`` or its alias ``path_following_mode`` (the seed's
  test example; when both are non-zero they must agree): 1 or 4 line following = strictly along
  virtual tracks (``KEY_POINTS``, fails without tracks), 2 free navigation, 3 intelligent =
  prefer virtual tracks but leave them to get around obstacles (``KEY_POINTS_WITH_OA``); 0 =
  intelligent;
* ``direction_constraint``: 3 (forward) and 0 (unset) drive forward; 4 (reverse) is rejected
  -- the robot's navigation only drives forward;
* ``gait``, ``height`` and ``obstacle_params.disable_body_obstacle_avoidance`` are legged-robot
  settings: validated (known values only) and otherwise ignored; the robot always avoids
  obstacles.

Feedback every 0.1 s: ``current_pose`` (the localized pose) and ``current_state`` (a
``NavState``: PLANNING, MOVING, RECOVERING; a last one ARRIVED, FAILED or CANCELED). Result
``{message, result}``: status 4 arrived, 6 failed (the robot's reason), 5 canceled
(``cancel_action_goal``; the robot stops). ``should_stop: true`` is a stop command: it cancels
every running goal of this action, stops the robot's current action and succeeds with
``"stopped"`` (no pose needed). A new goal replaces a running one, which ends ABORTED. A pose on
an obstacle of ``/map``, or nearer one than the robot's clearance, ends the goal at once (status
6, the reason as text, ``ground/placement.py``) and the robot does not move.

``/set_initialpose`` (``daystar_navigation_msgs/srv/SetInitialPose``): validate first, then
commit (:func:`~hitrobot_server.robot.relocalization.localize_near`). The robot's latest lidar
frame is matched against its map within ``SEARCH_HALF_SIZE`` m and ``SEARCH_YAW`` of
``init_pose``; only a match scoring at least ``MATCH_SCORE`` is committed as the robot's pose,
and ``result`` is true only when the robot's own localization quality then reaches
``GOOD_QUALITY`` (50). Otherwise ``result`` is false and the pose is what it was before the
call (a failed commit is rolled back). ``result_pose`` is the pose the robot believes after the
call. The covariance is not estimated by the robot: we report a diagonal with σ = 0.05 m /
0.05 rad when localized and 1 m / π otherwise.
"""

from __future__ import annotations

import logging
import math

from ..bus.core import Bus
from ..bus.errors import ServiceError
from ..bus.services import (
    STATUS_ABORTED,
    STATUS_CANCELED,
    STATUS_SUCCEEDED,
    GoalHandle,
    GoalOutcome,
)
from ..robot.backend import BackendError, NotConnectedError
from ..robot.capabilities import Robot
from ..robot.model import (
    ActionInfo,
    MoveOptionFlag,
    MoveOptions,
    NavigationMode,
    Odometry,
    Point2D,
    Pose2D,
)
from ..robot.motion import drive
from ..robot.relocalization import localize_near
from .base import RobotNode
from .ground.messages import GoalRejected, goal_pose, map_frames, pose_stamped, rejected
from .ground.placement import target_problem
from .ground.requests import NOT_CONNECTED, robot_error

log = logging.getLogger(__name__)

ACTION = "/intelligent_navigate_to_pose"
ACTION_ALIASES = ("/nav/intelligent_navigate_to_pose", "/intelligent_navigat_to_pose")
"""The vendor's test command's name, and the seed table's own spelling of the action name."""
ACTION_TYPE = "daystar_navigation_msgs/action/IntelligentNavitateToPose"
SERVICE = "/set_initialpose"
SERVICE_TYPE = "daystar_navigation_msgs/srv/SetInitialPose"

# daystar_navigation_msgs constants
SPEED_RATIOS = {0: None, 2: 0.3, 1: 0.6, 3: 1.0}
GAITS = frozenset({0, 2, 5, 6, 7})
HEIGHTS = frozenset({0, 1, 2, 3})
LINE_FOLLOWING = frozenset({1, 4})
FREE, INTELLIGENT = 2, 3
FORWARD, REVERSE = 3, 4
IDLE, PLANNING, MOVING, ARRIVED, FAILED, CANCELED, RECOVERING = range(7)



def _options(goal: dict) -> tuple[MoveOptions, str]:
    """Move options from the travel parameters, plus a summary for the log."""
    tp = goal["travel_params"]
    speed = tp["speed_mode"]["value"]
    if speed not in SPEED_RATIOS:
        raise GoalRejected(f"field 'travel_params.speed_mode.value': {speed} is not 0-3 "
                           "(2 low, 1 medium, 3 high)")
    gait = tp["gait"]["gait"]
    if gait not in GAITS:
        raise GoalRejected(f"field 'travel_params.gait.gait': {gait} is not one of 0, 2, 5, 6, 7")
    if tp["height"] not in HEIGHTS:
        raise GoalRejected(f"field 'travel_params.height': {tp['height']} is not 0-3")
    nav, alias = tp["nav_mode"]["value"], tp["path_following_mode"]
    if nav and alias and nav != alias:
        raise GoalRejected(f"'travel_params.nav_mode.value' ({nav}) and its alias "
                           f"'travel_params.path_following_mode' ({alias}) disagree")
    mode = alias or nav or INTELLIGENT
    direction = tp["direction_constraint"]
    if direction == REVERSE:
        raise GoalRejected("'travel_params.direction_constraint' 4 (reverse) is not supported: "
                           "this robot's navigation only drives forward")
    if direction not in (0, FORWARD):
        raise GoalRejected(f"field 'travel_params.direction_constraint': {direction} is not "
                           "3 (forward) or 4 (reverse)")
    flags = MoveOptionFlag.PRECISE
    if not tp["ignore_final_yaw"]:
        flags |= MoveOptionFlag.WITH_YAW
    if mode in LINE_FOLLOWING:
        flags |= MoveOptionFlag.KEY_POINTS
        nav_mode = NavigationMode.STRICT_VIRTUAL_TRACK
    elif mode == FREE:
        nav_mode = NavigationMode.FREE
    elif mode == INTELLIGENT:
        flags |= MoveOptionFlag.KEY_POINTS_WITH_OA
        nav_mode = NavigationMode.PRIORITY_VIRTUAL_TRACK
    else:
        raise GoalRejected(f"navigation mode {mode} is not 1/4 (line following), 2 (free) or "
                           "3 (intelligent)")
    return (MoveOptions(flags=flags, speed_ratio=SPEED_RATIOS[speed], mode=nav_mode),
            f"mode {mode}, speed {speed}, gait {gait}, height {tp['height']}")


def _state(action: ActionInfo) -> int:
    if action.stage == "PLANNING":
        return PLANNING
    if action.stage == "RECOVERING":
        return RECOVERING
    return MOVING


class IntelligentNavigationNode(RobotNode):
    """Serves the intelligent navigation action and the relocalization service."""

    GLOBAL_NAMES = ("/intelligent_navigation", ACTION, *ACTION_ALIASES, SERVICE)

    def __init__(self, bus: Bus, robot: Robot, map_frame: str = "/map"):
        super().__init__(bus, "/intelligent_navigation", robot.link)
        self.robot = robot
        self.map_frame = map_frame
        self.frames = map_frames(map_frame)
        self.running: set[GoalHandle] = set()
        for name in (ACTION, *ACTION_ALIASES):
            self.action(name, ACTION_TYPE, self._navigate)
        self.service(SERVICE, SERVICE_TYPE, self._set_initialpose)

    # ---------------------------------------------------------------- the action
    def _feedback(self, handle: GoalHandle, pose: Pose2D, state: int) -> None:
        handle.feedback({"current_pose": pose_stamped(pose, self.map_frame),
                         "current_state": {"value": state}})

    async def _navigate(self, handle: GoalHandle) -> GoalOutcome:
        goal = handle.goal
        if goal["should_stop"]:
            return await self._stop()
        try:
            target = goal_pose(self.frames, goal["pose"], "pose")
            options, summary = _options(goal)
            if not self.link.connected:
                raise GoalRejected(NOT_CONNECTED)
            if problem := target_problem(self.bus, "goal", target.x, target.y):
                raise GoalRejected(problem)
        except GoalRejected as exc:
            return rejected(str(exc))
        self.running.add(handle)
        try:
            def on_poll(action: ActionInfo, odometry: Odometry) -> None:
                self._feedback(handle, odometry.pose, _state(action))

            motion = self.robot.motion
            end = await drive(
                motion, handle.cancelled,
                lambda: motion.move_to([Point2D(target.x, target.y)], options, target.yaw),
                self.robot.sensors.get_odometry, on_poll)
        finally:
            self.running.discard(handle)
        try:
            pose = await self.robot.localization.get_pose()
        except BackendError:
            pose = target if end.kind == "succeeded" else None
        if end.kind == "succeeded":
            state, status, message = ARRIVED, STATUS_SUCCEEDED, f"arrived ({summary})"
        elif end.kind == "canceled":
            state, status, message = CANCELED, STATUS_CANCELED, "canceled"
        else:
            state, status, message = FAILED, STATUS_ABORTED, end.reason
        if pose is not None:
            self._feedback(handle, pose, state)
        return GoalOutcome(status, {"message": message, "result": end.kind == "succeeded"}, True)

    async def _stop(self) -> GoalOutcome:
        for other in list(self.running):
            other.cancel()
        try:
            current = await self.robot.motion.get_current_action()
            if current is not None:
                await self.robot.motion.cancel_action()
        except NotConnectedError:
            return rejected(NOT_CONNECTED)
        except BackendError as exc:
            return GoalOutcome(STATUS_ABORTED, {"message": f"stop failed: {exc}",
                                                "result": False}, True)
        return GoalOutcome(STATUS_SUCCEEDED, {"message": "stopped", "result": True}, True)

    # ---------------------------------------------------------------- the service
    async def _set_initialpose(self, request: dict) -> dict:
        init = request["init_pose"]
        try:
            pose = goal_pose(self.frames, {"header": init["header"], "pose": init["pose"]["pose"]},
                             "init_pose")
        except GoalRejected as exc:
            raise ServiceError(f"set_initialpose: {exc}") from None
        try:
            good, refined, why = await localize_near(self.robot, pose)
        except BackendError as exc:
            raise ServiceError(f"set_initialpose: {robot_error(exc)}") from None
        log.info("set_initialpose (%.2f, %.2f, %.2f): %s", pose.x, pose.y, pose.yaw, why)
        sigma_xy, sigma_yaw = (0.05, 0.05) if good else (1.0, math.pi)
        covariance = [0.0] * 36
        covariance[0] = covariance[7] = sigma_xy ** 2
        covariance[35] = sigma_yaw ** 2
        stamped = pose_stamped(refined, self.map_frame)
        return {"result": good,
                "result_pose": {"header": stamped["header"],
                                "pose": {"pose": stamped["pose"], "covariance": covariance}}}

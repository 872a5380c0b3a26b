"""``/navigation``: drive the robot to a pose or to a named POI (``map_messages``).

``/navigation/start`` (StartNavigation) and ``/navigation/navigate_to_poi`` (NavigateToPOI) start
a ``move_to`` on the robot:

* ``distance_to_target`` > 0 is the arrival tolerance (``MoveOptions.acceptable_precision``);
  0 keeps the robot's default;
* ``skip_final_turn`` leaves out the final turn to the goal's orientation (no ``WITH_YAW``);
* ``fast_planning`` confines the planner to the bounding box of the robot and the goal, grown
  by :data:`FAST_PLANNING_MARGIN` on every side (``MoveOptions.planning_area``), so a goal
  reachable only by a detour outside it is unreachable.

The map manager's BLOCKED/OBSTACLE masks are already in the robot's planner. A goal on an
obstacle of ``/map``, or nearer one than the robot's clearance, is refused before the robot
moves (``ground/placement.py``), unreachable as any other. When the robot
cannot get there (no path, stuck, blocked), ``/navigation/target_unreachable`` gets a
TargetUnreachable with the reason's constant and the requester a status error; arrival is an
``info`` status. A newer navigation (or any other motion request) replaces a running one
silently, as on the robot.
"""

from __future__ import annotations

from ..bus.core import Bus
from ..bus.topics import Message, RequestRejected
from ..robot.backend import (
    Link,
    LocalizationBackend,
    MotionBackend,
)
from ..robot.model import ActionResult, MoveOptionFlag, MoveOptions, Point2D, Rect
from ..robot.motion import follow
from .base import RobotNode, require_finite
from .ground import messages as m
from .ground.claims import MotionClaims
from .ground.placement import target_problem
from .ground.pois import find_poi
from .ground.requests import answer, require_robot

NODE_NAME = "/navigation"
PKG = "map_messages"
START_TOPIC = f"{NODE_NAME}/start"
POI_TOPIC = f"{NODE_NAME}/navigate_to_poi"
UNREACHABLE_TOPIC = f"{NODE_NAME}/target_unreachable"
FAST_PLANNING_MARGIN = 1.0
"""Metres added around the robot-goal bounding box for ``fast_planning``."""

UNKNOWN, TILT_OCCURED, GRAVE_TILT_OCCURED, STALL_OCCURED, LASER_OBSTACLE = 0, 10, 15, 20, 30


def unreachable_reason(text: str) -> int:
    """The TargetUnreachable constant for a robot's failure text: tilts, a stall (stuck), an
    obstacle (blocked path, collision), anything else (no path at all) UNKNOWN."""
    t = text.lower()
    if "tilt" in t:
        return GRAVE_TILT_OCCURED if "grave" in t else TILT_OCCURED
    if "stuck" in t or "stall" in t:
        return STALL_OCCURED
    if "obstacle" in t or "blocked" in t:
        return LASER_OBSTACLE
    return UNKNOWN


def planning_area(start: tuple[float, float], goal: tuple[float, float],
                  margin: float = FAST_PLANNING_MARGIN) -> Rect:
    """The robot-goal bounding box grown by ``margin``."""
    x0, x1 = sorted((start[0], goal[0]))
    y0, y1 = sorted((start[1], goal[1]))
    return Rect(x0 - margin, y0 - margin, x1 - x0 + 2 * margin, y1 - y0 + 2 * margin)


class NavigationNode(RobotNode):
    """StartNavigation / NavigateToPOI on top of the robot's ``move_to``."""

    GLOBAL_NAMES = (NODE_NAME,)

    def __init__(self, bus: Bus, link: Link, motion: MotionBackend,
                 localization: LocalizationBackend, claims: MotionClaims | None = None):
        super().__init__(bus, NODE_NAME, link)
        self.motion = motion
        self.claims = claims or MotionClaims()  # who took the robot over from a navigation
        self.localization = localization
        self.advertise(UNREACHABLE_TOPIC, f"{PKG}/TargetUnreachable")
        self.subscribe(START_TOPIC, f"{PKG}/StartNavigation", self._on_start)
        self.subscribe(POI_TOPIC, f"{PKG}/NavigateToPOI", self._on_poi)

    def _on_start(self, message: Message) -> None:
        msg = message.msg
        self._navigate(message, "navigation/start", msg["goal"], msg["distance_to_target"],
                       bool(msg["skip_final_turn"]), bool(msg["fast_planning"]))

    def _on_poi(self, message: Message) -> None:
        """The POI is read from the map manager (over the bus, as every node reads POIs), then
        the request goes on as a ``start`` to its pose; a refusal reaches the publisher as the
        bus words one."""
        msg = message.msg
        name = msg["poi_name"]

        async def to_poi() -> None:
            try:
                poi = await find_poi(self.bus, name)
            except Exception as exc:
                message.reply.fail(f"navigate_to_poi: the POIs cannot be read: {exc}")
                return
            try:
                if poi is None:
                    raise RequestRejected(f"navigate_to_poi: there is no POI named {name!r}")
                self._navigate(message, f"navigate_to_poi {name!r}", poi["pose"],
                               msg["distance_to_target"], bool(msg["skip_final_turn"]), False)
            except RequestRejected as exc:
                message.reply.fail(str(exc))

        self.spawn(to_poi())

    def _navigate(self, message: Message, what: str, goal: dict, distance: float,
                  skip_final_turn: bool, fast_planning: bool) -> None:
        position, q = goal["position"], goal["orientation"]
        require_finite("goal.position", position["x"], position["y"])
        require_finite("goal.orientation", q["x"], q["y"], q["z"], q["w"])
        require_finite("distance_to_target", distance)
        if distance < 0:
            raise RequestRejected("field 'distance_to_target' must not be negative")
        require_robot(self.link, what)
        target = Point2D(float(position["x"]), float(position["y"]))
        if problem := target_problem(self.bus, "goal", target.x, target.y):
            self.publish(UNREACHABLE_TOPIC, {"reason": unreachable_reason(problem)})
            raise RequestRejected(f"{what}: target unreachable: {problem}")
        yaw = m.yaw_of(q)
        reply = message.reply

        async def navigate() -> None:
            area = None
            if fast_planning:
                pose = await self.localization.get_pose()
                area = planning_area((pose.x, pose.y), (target.x, target.y))
            options = MoveOptions(
                flags=MoveOptionFlag.NONE if skip_final_turn else MoveOptionFlag.WITH_YAW,
                acceptable_precision=float(distance) if distance > 0 else None,
                planning_area=area,
            )
            action = await follow(self.motion,
                                  await self.motion.move_to([target], options, yaw))
            if action is None:  # replaced and forgotten
                return
            if action.result == ActionResult.SUCCESS:
                reply.ok(f"{what}: arrived")
            elif action.result == ActionResult.FAILED:
                why = action.reason or "unknown"
                self.publish(UNREACHABLE_TOPIC, {"reason": unreachable_reason(why)})
                reply.fail(f"{what}: target unreachable: {why}")
            elif by := self.claims.taken_by(action.action_id):  # someone took the robot over
                reply.warn(f"{what}: taken over by {by}")
            else:  # cancelled or superseded by another motion: not an error
                reply.info(f"{what}: {action.reason or 'cancelled'}")

        self.spawn(answer(reply, what, navigate()))

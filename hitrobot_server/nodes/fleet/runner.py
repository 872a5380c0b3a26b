"""Running one task on one robot over the bus: each leg planned (``/NAME/compute_path_to_pose``)
and driven (``/NAME/follow_path``), a dwell at each stop; a charge is the robot's own go-home
(its Slamware ``go_home`` topic), then waiting on the dock until the battery is back up."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Awaitable, Callable

from ...bus.core import Bus
from ...bus.namespace import Namespace
from ...bus.services import STATUS_CANCELED, STATUS_SUCCEEDED
from ...robot.model import Pose2D
from ..ground import messages as m
from ..ground.names import COMPUTE_PATH, FOLLOW_PATH
from .crossing import cross, path_points, piece
from .member import CHARGING
from .policy import ChargePolicy
from .tasks import CHARGE, RUNNING, Stop, Task
from .traffic import Traffic

GO_HOME = "/slamware_ros_sdk_server_node/go_home"
GO_HOME_TYPE = "slamware_ros_sdk/GoHomeRequest"
DOCK_TIMEOUT = 600.0
"""Seconds a robot has to reach its dock and start charging."""

PLANNERS = 2
"""Plans the fleet runs at once (each bid is one; they wait their turn)."""
NO_PATH_CELL = 0.25
NO_PATH_SECONDS = 10.0
NO_PATH_KEPT = 1000
BLOCKED_RETRIES = 2
"""Times a leg stopped on its way is planned again from where the robot stands."""
BLOCKED_WAIT = 2.0
"""Seconds before a leg with no path is planned again on a site with zones (another robot may
stand on the way or on the spot, waiting before a zone or coming out of it)."""

WaitMember = Callable[[str, Callable[[dict], bool], float], Awaitable[dict | None]]


def plain(reason: str, action: str) -> str:
    """A robot action's reason without the action's name before it (a task's words are the
    operator's: "stopped on the robot: cancelled", not "follow_path: stopped ...")."""
    return reason.removeprefix(f"{action.strip('/')}: ")


class TaskFailed(Exception):
    """The task did not happen; the text is why."""


class TaskRunner:
    def __init__(self, bus: Bus, map_frame: str, policy: ChargePolicy,
                 wait_member: WaitMember, advertise: Callable[[str, str], None],
                 traffic: Traffic):
        self.bus, self.map_frame, self.policy = bus, map_frame, policy
        self.wait_member, self.advertise = wait_member, advertise
        self.traffic = traffic
        self._planning = asyncio.Semaphore(PLANNERS)
        self._no_path: dict[tuple[str, int, int], tuple[float, str]] = {}

    async def plan(self, robot: str, target: Pose2D,
                   start: Pose2D | None = None) -> tuple[float, dict | None, str]:
        """The path's length, the path (None when there is none) and the planner's reason.
        At most :data:`PLANNERS` plans at a time; a place found unreachable is not planned
        again for :data:`NO_PATH_SECONDS` (a search that fails explores the whole map)."""
        loop = asyncio.get_running_loop()
        key = (robot, round(target.x / NO_PATH_CELL), round(target.y / NO_PATH_CELL))

        def known() -> tuple[float, str] | None:
            found = self._no_path.get(key)
            return found if found is not None and loop.time() - found[0] < NO_PATH_SECONDS \
                else None

        if (found := known()) is not None:  # at once: a burst does not queue for the planners
            return math.inf, None, found[1]
        async with self._planning:  # checked again: the plans queued behind one learn of it
            if (found := known()) is not None:
                return math.inf, None, found[1]
            length, path, reason = await self._plan(robot, target, start)
        if path is None:
            if len(self._no_path) >= NO_PATH_KEPT:
                self._no_path.clear()
            self._no_path[key] = (loop.time(), reason)
        return length, path, reason

    def forget_unreachable(self) -> None:
        self._no_path.clear()

    async def _plan(self, robot: str, target: Pose2D,
                    start: Pose2D | None) -> tuple[float, dict | None, str]:
        goal = {"goal": m.pose_stamped(target, self.map_frame),
                "start": m.pose_stamped(start or Pose2D(0, 0, 0), self.map_frame),
                "use_start": start is not None, "planner_id": ""}
        try:
            _handle, outcome = self.bus.start_goal(Namespace(robot).resolve(COMPUTE_PATH), goal)
            result = await outcome
        except Exception as exc:
            return math.inf, None, str(exc)
        if result.status != STATUS_SUCCEEDED or not isinstance(result.values, dict):
            return math.inf, None, plain(result.values, COMPUTE_PATH) if isinstance(
                result.values, str) else "no path"
        path = result.values["path"]
        points = [(p["pose"]["position"]["x"], p["pose"]["position"]["y"]) for p in path["poses"]]
        return sum(math.dist(a, b) for a, b in zip(points, points[1:], strict=False)), path, ""

    async def run(self, task: Task, robot: str, changed: Callable[[], None]) -> None:
        """Drive ``task`` to its end on ``robot`` (``TaskFailed`` when it cannot)."""
        if task.kind == CHARGE:
            await self._charge(task, robot, changed)
            return
        route = task.route
        while task.leg < len(route):
            if task.state != RUNNING:  # paused or cancelled meanwhile
                return
            stop = route[task.leg]
            await self._leg(task, robot, stop, changed)
            if task.state != RUNNING:  # paused or cancelled while it waited for a zone
                return
            if stop.dwell > 0:
                task.message = f"{robot} at {stop.name or 'the pose'} for {stop.dwell:g} s"
                changed()
                await asyncio.sleep(stop.dwell)
            task.leg += 1
            if task.leg < len(route):
                task.message = f"{robot} on leg {task.leg + 1} of {len(route)}"
                changed()

    async def _leg(self, task: Task, robot: str, stop: Stop,
                   changed: Callable[[], None]) -> None:
        """Plan and drive one leg through the zones; on a site with zones, a leg stopped on the
        way (another robot in its way: one waiting before a zone, or one coming out of it) is
        planned again from where the robot stands, :data:`BLOCKED_RETRIES` times, and so is a
        leg that finds no path there (after :data:`BLOCKED_WAIT`, not from the cache of places
        found unreachable: a robot in the way moves on)."""
        for attempt in range(BLOCKED_RETRIES + 1):
            if attempt == 0:
                _length, path, reason = await self.plan(robot, stop.pose)
            else:
                async with self._planning:
                    _length, path, reason = await self._plan(robot, stop.pose, None)
            if path is None:
                if attempt == BLOCKED_RETRIES or task.state != RUNNING or \
                        not self.traffic.zones:
                    raise TaskFailed(f"no path to {stop.name or 'the pose'}: {reason}")
                await asyncio.sleep(BLOCKED_WAIT)
                if task.state != RUNNING:
                    return
                continue
            try:
                await cross(self.traffic, task, robot, path, self._follow, changed)
                return
            except TaskFailed:
                if attempt == BLOCKED_RETRIES or task.state != RUNNING or \
                        not self.traffic.zones:
                    raise

    async def _follow(self, task: Task, robot: str, path: dict,
                      on_feedback: Callable[[dict], None] | None) -> None:
        try:
            handle, outcome_task = self.bus.start_goal(
                Namespace(robot).resolve(FOLLOW_PATH),
                {"path": path, "controller_id": "", "goal_checker_id": ""}, on_feedback)
            task.goal = handle
            outcome = await outcome_task
        except Exception as exc:
            raise TaskFailed(str(exc)) from None
        finally:
            task.goal = None
        if outcome.status != STATUS_SUCCEEDED:
            reason = plain(outcome.values, FOLLOW_PATH) if isinstance(outcome.values, str) \
                else ""
            if outcome.status == STATUS_CANCELED and not reason:
                reason = "its motion was stopped"
            raise TaskFailed(reason or "the path was not followed")

    async def _to_dock_through_zones(self, task: Task, robot: str,
                                     changed: Callable[[], None]) -> None:
        """A charge's way to the dock through mutex zones: driven (holding each zone) to the
        far side of the last zone on it; ``go_home`` docks the robot from there."""
        here = await self.wait_member(robot, lambda r: r["has_dock"], 0.0)
        if not self.traffic.zones or here is None:
            return
        _length, path, _reason = await self.plan(robot, m.pose2d(here["dock"]))
        runs = self.traffic.runs(path_points(path)) if path is not None else []
        if runs:  # else go_home finds its own way (or says why it cannot)
            await cross(self.traffic, task, robot, piece(path, 0, runs[-1].exit),
                        self._follow, changed)

    async def _charge(self, task: Task, robot: str, changed: Callable[[], None]) -> None:
        await self._to_dock_through_zones(task, robot, changed)
        if task.state != RUNNING:  # paused or cancelled while it waited for a zone
            return
        topic = Namespace(robot).resolve(GO_HOME)
        self.advertise(topic, GO_HOME_TYPE)
        self.bus.publish(topic, {})
        docked = await self.wait_member(robot, lambda r: r["state"] == CHARGING, DOCK_TIMEOUT)
        if docked is None:
            raise TaskFailed(f"{robot} did not reach its dock in {DOCK_TIMEOUT:.0f} s")
        until = self.policy.charge_until
        full = await self.wait_member(robot, lambda r: r["battery"] >= until or
                                      r["state"] not in (CHARGING, "idle"), math.inf)
        if full is None or full["battery"] < until:
            raise TaskFailed(f"{robot} left its dock at {(full or {}).get('battery', 0):.0f} %")

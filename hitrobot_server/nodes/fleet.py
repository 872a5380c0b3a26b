"""The fleet: every named robot's state in one list, dispatch to the nearest idle robot, a task
queue.

Each named robot runs a :class:`FleetMemberNode` (on its namespaced view of the bus) that
publishes its state on the site-wide ``/fleet/members`` twice a second. The site's
:class:`FleetNode` collects them — from this server or, over ``--bus zenoh``, from others — and
serves:

* ``/fleet/robots`` (``hitrobot_msgs/FleetRobots``, latched, 2 Hz): name, pose, state
  (idle/moving/charging/error/offline), battery and current task of every robot; a robot not
  heard from for :data:`OFFLINE_AFTER` s is offline.
* ``/fleet/dispatch`` (``hitrobot_msgs/Dispatch``): a POI name (from ``/map_manager``) or a pose,
  optionally a robot. Without a robot the nearest idle robot *by path length* (each idle robot's
  ``/NAME/compute_path_to_pose``) takes it; when none is idle the task waits in the queue. An
  unknown POI or robot, or every robot offline, is refused with the reason.
* ``/fleet/tasks`` (``hitrobot_msgs/FleetTasks``, latched): the queue. A task runs as the robot's
  ``/NAME/follow_path`` along the planned path; a failed task is reported and offered once to
  another robot. ``/fleet/cancel`` (``hitrobot_msgs/CancelTask``) cancels a queued or running one.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from dataclasses import dataclass, field

from ..bus.core import Bus
from ..bus.namespace import Namespace
from ..bus.services import STATUS_CANCELED, STATUS_SUCCEEDED, GoalHandle
from ..bus.topics import RequestRejected
from ..robot.backend import BackendError
from ..robot.capabilities import Robot
from ..robot.model import HealthLevel, Pose2D
from .base import RobotNode
from .ground import messages as m
from .ground.names import COMPUTE_PATH, FLEET_MEMBERS, FOLLOW_PATH
from .ground.pois import find_poi
from .ground.requests import NOT_CONNECTED

log = logging.getLogger(__name__)

PKG = "hitrobot_msgs"
MEMBERS = FLEET_MEMBERS
ROBOTS = "/fleet/robots"
TASKS = "/fleet/tasks"
DISPATCH = "/fleet/dispatch"
CANCEL = "/fleet/cancel"
PERIOD = 0.5  # /fleet/robots and /fleet/members: 2 Hz
OFFLINE_AFTER = 3.0
KEEP_FINISHED = 20  # finished tasks listed on /fleet/tasks
IDLE, MOVING, CHARGING, ERROR, OFFLINE = "idle", "moving", "charging", "error", "offline"


class FleetMemberNode(RobotNode):
    """One named robot's state on ``/fleet/members`` (2 Hz)."""

    def __init__(self, bus: Bus, robot: Robot, name: str):
        super().__init__(bus, "/fleet_member", robot.link)
        self.motion, self.localization = robot.motion, robot.localization
        self.sensors, self.power = robot.sensors, robot.power
        self.robot = name
        self.advertise(MEMBERS, f"{PKG}/FleetRobot")

    async def start(self) -> None:
        self.every(PERIOD, self._publish, needs_robot=False)

    async def _publish(self) -> None:
        self.publish(MEMBERS, await self.state())

    async def state(self) -> dict:
        msg = {"name": self.robot, "pose": m.pose(Pose2D(0, 0, 0)), "state": OFFLINE,
               "battery": 0.0, "task": 0, "message": NOT_CONNECTED}
        if not self.link.connected:
            return msg
        try:
            pose, action, power, health = (
                await self.localization.get_pose(), await self.motion.get_current_action(),
                await self.power.get_power_status(), await self.sensors.get_health())
        except BackendError as exc:
            return {**msg, "message": str(exc)}
        msg.update(pose=m.pose(pose), battery=float(power.battery_percentage), message="")
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


@dataclass
class Task:
    id: int
    poi: str
    pose: Pose2D
    robot: str  # asked for ("" = any)
    assigned: str = ""
    state: str = "queued"
    message: str = "waiting for an idle robot"
    tried: list[str] = field(default_factory=list)
    goal: GoalHandle | None = None

    def msg(self) -> dict:
        return {"id": self.id, "poi": self.poi, "pose": m.pose(self.pose), "robot": self.robot,
                "assigned": self.assigned, "state": self.state, "message": self.message,
                "tried": list(self.tried)}


class Refused(Exception):
    """A dispatch that cannot be accepted; the text is the reply's message."""


class FleetNode(RobotNode):
    """``/fleet/robots``, ``/fleet/dispatch``, ``/fleet/tasks``, ``/fleet/cancel``."""

    GLOBAL_NAMES = ("/fleet",)

    def __init__(self, bus: Bus, map_frame: str = "/map"):
        super().__init__(bus, "/fleet", None)
        self.map_frame = map_frame
        self.members: dict[str, tuple[float, dict]] = {}  # name → (heard at, FleetRobot)
        self.tasks: dict[int, Task] = {}
        self._next_id = 1
        self._busy: set[str] = set()  # robots a task was handed to and not yet finished
        self._wake: asyncio.Event | None = None
        self.advertise(ROBOTS, f"{PKG}/FleetRobots", latch=True)
        self.advertise(TASKS, f"{PKG}/FleetTasks", latch=True)
        self.subscribe(MEMBERS, f"{PKG}/FleetRobot", self._on_member)
        self.service(DISPATCH, f"{PKG}/Dispatch", self._dispatch)
        self.service(CANCEL, f"{PKG}/CancelTask", self._cancel)
        self._publish_tasks()

    async def start(self) -> None:
        self._wake = asyncio.Event()
        self.every(PERIOD, self._publish_robots, needs_robot=False)
        self.spawn(self._assign_loop())

    # ------------------------------------------------------------------ robots
    def _on_member(self, message) -> None:
        msg = message.msg
        self.members[msg["name"]] = (time.monotonic(), msg)
        if msg["state"] == IDLE and self._wake is not None:
            self._wake.set()

    def robots(self) -> list[dict]:
        now = time.monotonic()
        running = {t.assigned: t.id for t in self.tasks.values() if t.state == "running"}
        out = []
        for name in sorted(self.members):
            heard, msg = self.members[name]
            msg = dict(msg, task=running.get(name, 0))
            if now - heard > OFFLINE_AFTER:
                msg.update(state=OFFLINE, message=f"not heard from for {now - heard:.0f} s")
            out.append(msg)
        return out

    def idle(self) -> list[str]:
        return [r["name"] for r in self.robots()
                if r["state"] == IDLE and r["name"] not in self._busy]

    async def _publish_robots(self) -> None:
        self.publish(ROBOTS, {"robots": self.robots()})

    def _publish_tasks(self) -> None:
        self.publish(TASKS, {"tasks": [t.msg() for t in self.tasks.values()]})

    # ------------------------------------------------------------------ requests
    async def _dispatch(self, request: dict) -> dict:
        try:
            task = await self._new_task(request)
        except Refused as exc:
            return {"robot": "", "accepted": False, "message": str(exc), "task": 0}
        self.tasks[task.id] = task
        self._forget_finished()
        robot = await self._try_assign(task)
        self._publish_tasks()
        if robot:
            return {"robot": robot, "accepted": True, "task": task.id,
                    "message": f"task {task.id}: {robot} is on its way"}
        return {"robot": "", "accepted": True, "task": task.id,
                "message": f"task {task.id} queued: {task.message}"}

    async def _new_task(self, request: dict) -> Task:
        robots = {r["name"]: r for r in self.robots()}
        wanted = request["robot"]
        if wanted and wanted not in robots:
            raise Refused(f"unknown robot '{wanted}' (robots: {', '.join(robots) or 'none'})")
        if not robots or all(r["state"] == OFFLINE for r in robots.values()):
            raise Refused("every robot is offline")
        if wanted and robots[wanted]["state"] == OFFLINE:
            raise Refused(f"robot '{wanted}' is offline")
        poi = request["poi"]
        if poi:
            pose = await self._poi_pose(poi)
        else:
            try:
                pose = m.pose2d_of(request["pose"], "pose")
            except RequestRejected as exc:
                raise Refused(str(exc)) from None
        task = Task(self._next_id, poi, pose, wanted)
        self._next_id += 1
        return task

    async def _poi_pose(self, name: str) -> Pose2D:
        try:
            poi = await find_poi(self.bus, name)
        except Exception as exc:
            raise Refused(f"the POIs cannot be read: {exc}") from None
        if poi is None:
            raise Refused(f"unknown POI '{name}'")
        return m.pose2d(poi["pose"])

    async def _cancel(self, request: dict) -> dict:
        task = self.tasks.get(request["task"])
        if task is None:
            return {"success": False, "message": f"no task {request['task']}"}
        if task.state not in ("queued", "running"):
            return {"success": False, "message": f"task {task.id} already {task.state}"}
        if task.goal is not None:
            task.goal.cancel()
        task.state, task.message = "cancelled", "cancelled"
        self._publish_tasks()
        return {"success": True, "message": f"task {task.id} cancelled"}

    # ------------------------------------------------------------------ assignment
    async def _assign_loop(self) -> None:
        assert self._wake is not None
        while True:
            await self._wake.wait()
            self._wake.clear()
            for task in [t for t in self.tasks.values() if t.state == "queued"]:
                if await self._try_assign(task):
                    self._publish_tasks()

    async def _try_assign(self, task: Task) -> str:
        """Hand ``task`` to the nearest idle robot it may go to; ``""`` when none is idle."""
        candidates = [r for r in self.idle()
                      if r not in task.tried and (not task.robot or r == task.robot)]
        if not candidates:
            return ""
        plans = await asyncio.gather(*(self._plan(r, task.pose) for r in candidates))
        reachable = [(length, name, path) for name, (length, path) in zip(candidates, plans,
                                                                            strict=True)
                     if path is not None]
        if not reachable or task.state != "queued":
            if not reachable:
                task.message = "no idle robot can reach the target"
            return ""
        _length, robot, path = min(reachable, key=lambda x: (x[0], x[1]))
        task.state, task.assigned = "running", robot
        task.message = f"{robot} is on its way"
        self._busy.add(robot)
        self.spawn(self._run(task, robot, path))
        return robot

    async def _plan(self, robot: str, target: Pose2D) -> tuple[float, dict | None]:
        goal = {"goal": m.pose_stamped(target, self.map_frame), "start": m.pose_stamped(
            Pose2D(0, 0, 0), self.map_frame), "use_start": False, "planner_id": ""}
        try:
            _handle, outcome = self.bus.start_goal(Namespace(robot).resolve(COMPUTE_PATH), goal)
            result = await outcome
        except Exception as exc:
            log.info("fleet: %s cannot plan: %s", robot, exc)
            return math.inf, None
        if result.status != STATUS_SUCCEEDED or not isinstance(result.values, dict):
            return math.inf, None
        path = result.values["path"]
        points = [(p["pose"]["position"]["x"], p["pose"]["position"]["y"]) for p in path["poses"]]
        length = sum(math.dist(a, b) for a, b in zip(points, points[1:], strict=False))
        return length, path

    async def _run(self, task: Task, robot: str, path: dict) -> None:
        try:
            handle, outcome_task = self.bus.start_goal(
                Namespace(robot).resolve(FOLLOW_PATH),
                {"path": path, "controller_id": "", "goal_checker_id": ""})
            task.goal = handle
            outcome = await outcome_task
        except Exception as exc:
            outcome = None
            reason = str(exc)
        else:
            reason = outcome.values if isinstance(outcome.values, str) else ""
        finally:
            self._busy.discard(robot)
            task.goal = None
        if task.state == "cancelled":
            pass
        elif outcome is not None and outcome.status == STATUS_SUCCEEDED:
            task.state, task.message = "succeeded", f"{robot} arrived"
        else:  # aborted, or its motion stopped by someone else: the task did not happen
            if outcome is not None and outcome.status == STATUS_CANCELED and not reason:
                reason = "its motion was stopped"
            task.tried.append(robot)
            if len(task.tried) < 2 and not task.robot:
                task.state = "queued"
                task.message = f"{robot} failed ({reason}); offered to another robot"
            else:
                task.state, task.message = "failed", f"{robot} failed: {reason}"
            log.warning("fleet: task %d on %s failed: %s", task.id, robot, reason,
                        extra={"ros_node": self.name})
        self._publish_tasks()
        if self._wake is not None:
            self._wake.set()

    def _forget_finished(self) -> None:
        finished = [t.id for t in self.tasks.values()
                    if t.state not in ("queued", "running")]
        for task_id in finished[:-KEEP_FINISHED]:
            del self.tasks[task_id]

    async def stop(self) -> None:
        for task in self.tasks.values():
            if task.goal is not None:
                with contextlib.suppress(Exception):
                    task.goal.cancel()
        await super().stop()

"""The site's fleet node: the robots' list, dispatch by cost, the task lifecycle, the charging
policy, the history, schedules and robots taken out of service (see the package's docstring).

Nothing here runs on a timer but the 2 Hz list and the schedules' check: a task is handed out
when something happens (a robot becomes free, a task ends or is added, resumed, a robot comes
back into service), never by replanning in a loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime as dt
import logging
import time
from collections.abc import Callable

from ...bus.core import Bus
from ...state import StateBinding
from ..base import RobotNode
from .board import Board
from .dispatch import Dispatcher
from .leader import Leadership
from .member import CHARGING, IDLE, MEMBERS, OFFLINE, OFFLINE_AFTER, PERIOD, PKG
from .policy import ChargePolicy
from .policyinfo import PolicyService
from .replica import NotedMemory
from .runner import TaskFailed, TaskRunner
from .scheduling import ScheduleServices
from .tasks import (
    CANCELLED,
    CHARGE,
    FAILED,
    PAUSED,
    QUEUED,
    RUNNING,
    SUCCEEDED,
    Refused,
    Task,
)
from .zoning import ZoneServices

log = logging.getLogger(__name__)

ROBOTS, TASKS = "/fleet/robots", "/fleet/tasks"
SITE_MAP = "/map"


class FleetNode(RobotNode):
    """``/fleet/robots``, ``/fleet/tasks`` and the fleet's services."""

    GLOBAL_NAMES = ("/fleet",)

    def __init__(self, bus: Bus, map_frame: str = "/map", state: StateBinding | None = None,
                 policy: ChargePolicy | None = None, zone: dt.tzinfo | None = None,
                 clock: Callable[[], float] | None = None):
        super().__init__(bus, "/fleet", None)
        self.map_frame = map_frame
        self.policy = policy or ChargePolicy()
        self.clock = clock or time.time
        self.members: dict[str, tuple[float, dict]] = {}  # name → (heard at, FleetRobot)
        self.lead = Leadership(self, bus.link.group("fleet") if bus.link is not None else None)
        self.board = Board(state, NotedMemory(state, "fleet", self.lead.changed))
        self.lead.attach(self.board)
        self._restored = self.board.restore()
        self._busy: set[str] = set()  # robots running a task
        self._wake: asyncio.Event | None = None
        self._heard: dict[str, asyncio.Event] = {}
        self.zoning = ZoneServices(self, self.board.memory, self.advertise, self._publish_led)
        self._restored += self.zoning.restore()
        self.traffic = self.zoning.traffic
        self.runner = TaskRunner(bus, map_frame, self.policy, self.wait_member,
                                 self._advertise_once, self.traffic)
        self.dispatcher = Dispatcher(self)
        local = dt.datetime.now().astimezone().tzinfo  # the server's (a fixed offset)
        self.schedules = ScheduleServices(self, self.dispatcher.dispatch, zone or local)
        PolicyService(self, zone or local, self.clock)
        self._advertised: set[str] = set()
        self.advertise(ROBOTS, f"{PKG}/FleetRobots", latch=True)
        self.advertise(TASKS, f"{PKG}/FleetTasks", latch=True)
        self.subscribe(MEMBERS, f"{PKG}/FleetRobot", self._on_member)
        self.site_map: dict | None = None  # the site's /map: targets are checked on it
        self.subscribe(SITE_MAP, "nav_msgs/OccupancyGrid", self._on_map)
        for name, kind, handler in (
                ("dispatch", "Dispatch", self.lead.acknowledged(self.dispatcher.dispatch)),
                ("cancel", "CancelTask", self._cancel), ("pause", "CancelTask", self._pause),
                ("resume", "CancelTask", self._resume),
                ("history", "FleetHistory", self._history),
                ("set_in_service", "SetInService", self._set_in_service)):
            self.service(f"/fleet/{name}", f"{PKG}/{kind}", handler)
        self.publish_tasks()
        self.zoning.publish()

    def restored(self) -> list[str]:
        return self._restored

    async def start(self) -> None:
        self._wake = asyncio.Event()
        await self.lead.join()  # over Zenoh: dispatch or follow, before clients come (.leader)
        self.schedules.catch_up()
        self.every(PERIOD, self._tick, needs_robot=False)
        self.spawn(self._assign_loop())
        self.kick()

    async def _tick(self) -> None:
        if not self.lead.leading:
            return
        self.publish(ROBOTS, {"robots": self.robots()})
        await self.schedules.fire_due()

    # ------------------------------------------------------------------ robots
    def _on_member(self, message) -> None:
        msg = message.msg
        name = msg["name"]
        before = self.members.get(name, (0.0, {}))[1]
        self.members[name] = (time.monotonic(), msg)
        if (before.get("state") != msg["state"]
                or self._low(before.get("battery", 100.0)) != self._low(msg["battery"])):
            self.kick()
        self.traffic.moved(name)
        heard = self._heard.pop(name, None)
        if heard is not None:
            heard.set()

    def _on_map(self, message) -> None:
        """A new site map: targets found unreachable may be reachable now."""
        self.site_map = message.msg
        self.runner.forget_unreachable()

    def _low(self, battery: float) -> bool:
        return battery < self.policy.charge_below

    async def wait_member(self, robot: str, done: Callable[[dict], bool],
                          timeout: float) -> dict | None:
        """The robot's first report for which ``done`` holds; None after ``timeout`` s."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            msg = self.members.get(robot, (0.0, None))[1]
            if msg is not None and done(msg):
                return msg
            left = deadline - loop.time()
            if left <= 0:
                return None
            event = self._heard.setdefault(robot, asyncio.Event())
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(event.wait(), min(left, 3600.0))

    def robots(self) -> list[dict]:
        now = time.monotonic()
        running = {t.assigned: t.id for t in self.board.tasks.values() if t.state == RUNNING}
        out = []
        for name in sorted(self.members):
            heard, msg = self.members[name]
            msg = dict(msg, task=running.get(name, 0),
                       in_service=name not in self.board.out_of_service)
            if now - heard > OFFLINE_AFTER:
                msg.update(state=OFFLINE, message=f"not heard from for {now - heard:.0f} s")
            out.append(msg)
        return out

    def free(self) -> list[dict]:
        """Robots that may start a task now: heard from, in service, idle (or on the dock);
        none while this server does not hand out tasks (see .leader)."""
        if not self.lead.assigning:
            return []
        return [r for r in self.robots() if r["state"] in (IDLE, CHARGING) and r["in_service"]
                and r["name"] not in self._busy]

    def _publish_led(self, topic: str, msg: dict) -> None:
        """Publish a site-wide topic only while this server dispatches (a follower does not
        offer it: .leader)."""
        if self.lead.leading:
            self.publish(topic, msg)

    def publish_tasks(self) -> None:
        if self.lead.leading:
            self.publish(TASKS, {"tasks": [t.msg() for t in self.board.tasks.values()]})

    def took_over(self) -> None:
        """This server dispatches now: the zones copied from the last dispatcher apply."""
        self.zoning.reload()

    def changed(self) -> None:
        """A task changed: persist it, publish the list."""
        self.board.save()
        self.publish_tasks()

    def kick(self) -> None:
        if self._wake is not None:
            self._wake.set()

    def _advertise_once(self, topic: str, type_name: str) -> None:
        if topic not in self._advertised:
            self._advertised.add(topic)
            self.advertise(topic, type_name)

    # ------------------------------------------------------------------ assignment
    async def _assign_loop(self) -> None:
        assert self._wake is not None
        while True:
            await self._wake.wait()
            self._wake.clear()
            if not self.lead.assigning:
                continue
            self.dispatcher.charge_policy()
            for robot in self.free():
                task = self.dispatcher.next_for(robot)
                if task is not None:
                    self.start_task(task, robot["name"])

    def start_task(self, task: Task, robot: str) -> None:
        task.state, task.assigned, task.reserved = RUNNING, robot, ""
        task.started = task.started or self.clock()
        task.message = f"{robot} is on its way" if task.kind != CHARGE else \
            f"{robot} goes to charge"
        self._busy.add(robot)
        self.changed()
        self.spawn(self._run(task, robot))

    async def _run(self, task: Task, robot: str) -> None:
        reason = ""
        try:
            await self.lead.kept()  # the assignment is kept before the robot moves
            await self.runner.run(task, robot, self.publish_tasks)
        except TaskFailed as exc:
            reason = str(exc) or "failed"
        finally:
            self._busy.discard(robot)
        if task.state in (CANCELLED, PAUSED):
            pass
        elif not reason:
            self._finish(task, SUCCEEDED, f"{robot} arrived" if task.kind != CHARGE else
                         f"{robot} charged to {self.policy.charge_until:.0f} %")
        else:
            task.tried.append(robot)
            log.warning("fleet: task %d on %s failed: %s", task.id, robot, reason,
                        extra={"ros_node": self.name})
            if len(task.tried) < 2 and not task.robot and task.kind != CHARGE:
                task.state = QUEUED
                task.message = f"{robot} failed ({reason}); offered to another robot"
                self.changed()
                await self.dispatcher.rebid(task)
                return
            else:
                self._finish(task, FAILED, f"{robot} failed: {reason}")
        self.kick()

    def _finish(self, task: Task, state: str, message: str) -> None:
        task.state, task.message, task.finished = state, message, self.clock()
        self.board.finished(task)
        self.publish_tasks()

    # ------------------------------------------------------------------ requests
    def _task(self, request: dict) -> Task:
        task = self.board.tasks.get(request["task"])
        if task is None:
            raise Refused(f"no task {request['task']}")
        return task

    async def _cancel(self, request: dict) -> dict:
        try:
            task = self._task(request)
            if not task.open:
                raise Refused(f"task {task.id} already {task.state}")
        except Refused as exc:
            return {"success": False, "message": str(exc)}
        if task.goal is not None:
            task.goal.cancel()
        if task.state == RUNNING:
            self.traffic.withdraw(task.assigned)
        self._finish(task, CANCELLED, "cancelled")
        return {"success": True, "message": f"task {task.id} cancelled"}

    async def _pause(self, request: dict) -> dict:
        try:
            task = self._task(request)
            if task.state not in (QUEUED, RUNNING):
                raise Refused(f"task {task.id} is {task.state}, not queued or running")
        except Refused as exc:
            return {"success": False, "message": str(exc)}
        was = task.state
        task.state, task.message = PAUSED, f"paused ({was})"
        if task.goal is not None:
            task.goal.cancel()
        if was == RUNNING:
            self.traffic.withdraw(task.assigned)
        self.changed()
        return {"success": True, "message": f"task {task.id} paused"}

    async def _resume(self, request: dict) -> dict:
        try:
            task = self._task(request)
            if task.state != PAUSED:
                raise Refused(f"task {task.id} is {task.state}, not paused")
        except Refused as exc:
            return {"success": False, "message": str(exc)}
        task.state, task.message = QUEUED, "resumed; waiting for a robot"
        self.changed()
        self.kick()
        return {"success": True, "message": f"task {task.id} resumed"}

    async def _history(self, request: dict) -> dict:
        limit = int(request["limit"])
        return {"tasks": [Task.from_record(r).msg()
                          for r in self.board.recent(request["robot"], limit)]}

    async def _set_in_service(self, request: dict) -> dict:
        robot, serving = request["robot"], bool(request["in_service"])
        if robot not in self.members:
            return {"success": False, "message": f"unknown robot '{robot}'"}
        if serving:
            self.board.out_of_service.discard(robot)
        else:
            self.board.out_of_service.add(robot)
        self.board.save_service()
        moved = self.dispatcher.release(robot) if not serving else []
        self.changed()
        self.kick()
        text = f"{robot} is {'in' if serving else 'out of'} service"
        if moved:
            text += f"; its queued tasks {', '.join(map(str, moved))} go to others"
        return {"success": True, "message": text}

    def service(self, name: str, type_name: str, handler) -> None:
        self.lead.service(name, type_name, handler)  # offered while this server dispatches

    def advertise(self, topic: str, type_name: str, latch: bool = False) -> None:
        self.lead.advertise(topic, type_name, latch)

    async def stop(self) -> None:
        await self.lead.leave()
        for task in self.board.tasks.values():
            if task.goal is not None:
                with contextlib.suppress(Exception):
                    task.goal.cancel()
        await super().stop()
        store = self.board.memory.store
        if store is not None:  # the site's folder is the fleet's own (robots.py opens it)
            await store.close()

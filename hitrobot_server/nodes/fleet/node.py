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
from ..ground.memory import Handler, acknowledged
from ..ground.names import VDA5050_LINK
from .board import Board
from .dispatch import Dispatcher
from .leader import Leadership
from .member import CHARGING, IDLE, MEMBERS, MOVING, PERIOD, PKG, WAITING
from .policy import ChargePolicy
from .policyinfo import PolicyService
from .roster import Roster
from .runner import TaskFailed, TaskRunner
from .scheduling import ScheduleServices
from .takeover import TakeOver
from .taskrequests import TaskRequests
from .tasks import CHARGE, FAILED, QUEUED, RUNNING, SUCCEEDED, Task
from .zoning import ZoneServices

log = logging.getLogger(__name__)

ROBOTS, TASKS = "/fleet/robots", "/fleet/tasks"
SITE_MAP = "/map"


class FleetNode(RobotNode):
    """``/fleet/robots``, ``/fleet/tasks`` and the fleet's services: the wiring of its parts
    (each handed the parts and values it needs) and the hand-out of tasks to free robots."""

    GLOBAL_NAMES = ("/fleet",)

    def __init__(self, bus: Bus, map_frame: str = "/map", state: StateBinding | None = None,
                 policy: ChargePolicy | None = None, zone: dt.tzinfo | None = None,
                 clock: Callable[[], float] | None = None):
        super().__init__(bus, "/fleet", None)
        self.map_frame = map_frame
        self.policy = policy or ChargePolicy()
        self.clock = clock or time.time
        self.board = Board(state)
        self.roster = Roster(self.board, self.policy)
        take_over = TakeOver(self.board, self.roster, self.clock, self.start_task,
                             self.publish_tasks, self.name)
        group = bus.link.group("fleet") if bus.link is not None else None
        self.lead = Leadership(bus, self, self.name, group, self.board, self.spawn, take_over,
                               self.took_over)
        self._restored = self.board.restore()
        self._busy: set[str] = set()  # robots running a task
        self._wake: asyncio.Event | None = None
        self.site_map: dict | None = None  # the site's /map: targets are checked on it
        self.zoning = ZoneServices(self.board.memory, self.roster, lambda: self.site_map,
                                   self.service, self.advertise, self._publish_led)
        self._restored += self.zoning.restore()
        self.traffic = self.zoning.traffic
        self.runner = TaskRunner(bus, map_frame, self.policy, self.roster.wait_member,
                                 self._advertise_once, self.traffic)
        self.dispatcher = Dispatcher(
            self.board, self.roster, self.runner, self.policy, self.traffic, bus, self.clock,
            lambda: self.site_map, free=self.free, start_task=self.start_task, kick=self.kick,
            publish=self.publish_tasks)
        local = dt.datetime.now().astimezone().tzinfo  # the server's (a fixed offset)
        self.schedules = ScheduleServices(self.board, bus, self.clock, self.roster.robots,
                                          self.dispatcher.dispatch, zone or local, self.service)
        PolicyService(self.policy, zone or local, self.clock, self.service)
        self._advertised: set[str] = set()
        self.advertise(ROBOTS, f"{PKG}/FleetRobots", latch=True)
        self.advertise(TASKS, f"{PKG}/FleetTasks", latch=True)
        self.subscribe(MEMBERS, f"{PKG}/FleetRobot", self._on_member)
        self.subscribe(SITE_MAP, "nav_msgs/OccupancyGrid", self._on_map)
        self.subscribe(VDA5050_LINK, "hitrobot_msgs/VdaLinks",  # a master control's orders
                       lambda message: self.roster.vda_orders(message.msg["links"]))
        self.service("/fleet/dispatch", f"{PKG}/Dispatch", self.dispatcher.dispatch)
        TaskRequests(self.board, self.roster, self.traffic, finish=self._finish,
                     release=self.dispatcher.release, changed=self.changed, kick=self.kick,
                     serve=self.service, offer=self.dispatcher.offer,
                     offer_queued=lambda note: self.spawn(self.dispatcher.offer_queued(note)))
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
        self.publish(ROBOTS, {"robots": [self._waiting(r) for r in self.roster.robots()]})
        self.spawn(self.schedules.fire_due())

    # ------------------------------------------------------------------ robots
    def _on_member(self, message) -> None:
        if self.roster.heard(message.msg):
            self.kick()
        self.traffic.moved(message.msg["name"])

    def _on_map(self, message) -> None:
        """A new site map: targets found unreachable may be reachable now."""
        self.site_map = message.msg
        self.runner.forget_unreachable()

    def _waiting(self, robot: dict) -> dict:
        """A robot stopped before a mutex zone says it waits for it (not that it is idle)."""
        why = self.traffic.waiting_for(robot["name"])
        if not why or robot["state"] not in (IDLE, MOVING):
            return robot
        return {**robot, "state": WAITING, "message": why}

    def free(self) -> list[dict]:
        """Robots that may start a task now: heard from, in service, idle (or on the dock);
        none while this server does not hand out tasks (see .leader)."""
        if not self.lead.assigning:
            return []
        return [r for r in self.roster.robots() if r["state"] in (IDLE, CHARGING)
                and r["in_service"] and r["name"] not in self._busy]

    def _publish_led(self, topic: str, msg: dict) -> None:
        """Publish a site-wide topic only while this server dispatches (a follower does not
        offer it: .leader)."""
        if self.lead.leading:
            self.publish(topic, msg)

    def publish_tasks(self) -> None:
        if self.lead.leading:
            self.publish(TASKS, {"tasks": [t.msg() for t in self.board.tasks.values()]})

    def took_over(self) -> None:
        """This server dispatches now: the zones copied from the last dispatcher apply, the
        queue is kept and published, and free robots take work."""
        self.zoning.reload()
        self.changed()
        self.kick()

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
            await self.board.kept("an assignment")  # before the robot moves
            await self.runner.run(task, robot, self.publish_tasks)
        except TaskFailed as exc:
            reason = str(exc) or "failed"
        finally:
            self._busy.discard(robot)
        if task.state != RUNNING:  # cancelled, paused (and perhaps resumed since): it stands
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

    def service(self, name: str, type_name: str, handler: Handler) -> None:
        """Every fleet service: answered as the acknowledgement table says (a change once the
        board has it on disk and, over Zenoh, at the followers), offered while this server
        dispatches (.leader)."""
        self.lead.service(name, type_name, acknowledged(name, handler, self.board.durable))

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

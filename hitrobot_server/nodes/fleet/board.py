"""The fleet's tasks and what it remembers: the open tasks, the history of finished ones, the
schedules and the robots out of service, all kept in the site's state folder (they survive a
restart and a kill -9: each change is a journal line of the state store).

Bounds: :data:`MAX_OPEN` open tasks in all, :data:`MAX_PER_ROBOT` waiting for one named robot;
the history keeps the last :data:`HISTORY` finished tasks; ``/fleet/tasks`` lists the open ones
and the last :data:`KEEP_FINISHED` finished.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Coroutine
from typing import Any

from ...state import StateBinding
from ..ground.memory import NodeMemory, NotSaved
from .schedules import Schedule
from .tasks import QUEUED, RUNNING, Refused, Task

log = logging.getLogger(__name__)

MAX_OPEN = 200
MAX_PER_ROBOT = 50
HISTORY = 1000
KEEP_FINISHED = 20


class SignalledMemory(NodeMemory):
    """The board's sections; each put is also told to ``on_put`` (the board's change signal)."""

    def __init__(self, binding: StateBinding | None, prefix: str, on_put: Callable[[], None]):
        super().__init__(binding, prefix)
        self._on_put = on_put

    def put(self, name: str, value: Any) -> None:
        super().put(name, value)
        self._on_put()


class Board:
    """The fleet's state; its change signal (:meth:`on_change`) fires on each put of its
    sections, and :meth:`durable` says when the changes so far are kept."""

    def __init__(self, state: StateBinding | None):
        self.memory = SignalledMemory(state, "fleet", self._changed)
        self._listeners: list[Callable[[], None]] = []
        self._copies: list[Callable[[], Coroutine[Any, Any, str]]] = []
        self.tasks: dict[int, Task] = {}  # open, then the last finished
        self.history: list[dict] = []  # finished task records, oldest first
        self.schedules: dict[int, Schedule] = {}
        self.out_of_service: set[str] = set()
        self.next_id = 1
        self.next_schedule = 1

    def restore(self) -> list[str]:
        """Take back what the state folder kept; a task running at the stop is queued again."""
        try:
            for record in self.memory.get("open") or []:
                task = Task.from_record(record)
                task.reserved = ""  # bids are not kept: free robots take it
                if task.state == RUNNING:
                    task.state, task.message = QUEUED, "interrupted by a restart; queued again"
                self.tasks[task.id] = task
            self.history = list(self.memory.get("history") or [])[-HISTORY:]
            for record in self.memory.get("schedules") or []:
                schedule = Schedule.from_record(record)
                self.schedules[schedule.id] = schedule
            self.out_of_service = set(self.memory.get("out_of_service") or [])
            ids = self.memory.get("ids") or [1, 1]
            self.next_id, self.next_schedule = int(ids[0]), int(ids[1])
        except (KeyError, ValueError, TypeError) as exc:
            self.memory.reject("open", str(exc))
        phrases = []
        if self.tasks:
            phrases.append(f"{len(self.tasks)} fleet tasks")
        if self.history:
            phrases.append(f"a fleet history of {len(self.history)}")
        if self.schedules:
            phrases.append(f"{len(self.schedules)} schedules")
        return phrases

    # ------------------------------------------------------------------ change, kept
    def on_change(self, listener: Callable[[], None]) -> None:
        """Call ``listener`` on every change of the board's sections (the zones included)."""
        self._listeners.append(listener)

    def copied_by(self, copy: Callable[[], Coroutine[Any, Any, str]]) -> None:
        """``copy()`` (called when :meth:`durable` is) awaits the changes so far at the other
        servers: "" when they have them, else what is missing (the replica, over Zenoh)."""
        self._copies.append(copy)

    def _changed(self) -> None:
        for listener in self._listeners:
            listener()

    async def durable(self) -> str:
        """Once the changes so far are on disk and copied: "" or what is missing;
        ``NotSaved`` when the disk refused them."""
        copies = [copy() for copy in self._copies]  # the sends carrying the changes so far
        try:
            await self.memory.durable()
        except BaseException:
            for pending in copies:
                pending.close()
            raise
        missing = [await pending for pending in copies]
        return "".join(missing)

    async def kept(self, what: str) -> None:
        """:meth:`durable`, for a change nobody is answered about (an assignment, before its
        robot moves): what is missing is logged, not raised (a disk fault does not stop the
        site)."""
        try:
            missing = await self.durable()
        except NotSaved as exc:
            missing = str(exc)
        if missing:
            log.warning("fleet: %s was not kept: %s", what, missing.strip(" ()"),
                        extra={"ros_node": "/fleet"})  # on /rosout as the fleet node's

    # ------------------------------------------------------------------ tasks
    def new_id(self) -> int:
        self.next_id += 1
        return self.next_id - 1

    def check_room(self, robot: str) -> None:
        """Refuse a new task when the queue is full (in all, or for the named robot)."""
        open_tasks = [t for t in self.tasks.values() if t.open]
        if len(open_tasks) >= MAX_OPEN:
            raise Refused(f"the fleet's queue is full ({MAX_OPEN} open tasks); wait or cancel")
        if robot and sum(t.robot == robot for t in open_tasks) >= MAX_PER_ROBOT:
            raise Refused(f"robot '{robot}' already has {MAX_PER_ROBOT} tasks waiting")

    def add(self, task: Task) -> None:
        self.tasks[task.id] = task
        self.save()

    def finished(self, task: Task) -> None:
        """Into the history; the oldest finished fall off ``/fleet/tasks``."""
        self.history = [*self.history, task.record()][-HISTORY:]
        done = [t.id for t in self.tasks.values() if not t.open]
        for task_id in done[:-KEEP_FINISHED]:
            del self.tasks[task_id]
        self.memory.put("history", self.history)
        self.save()

    def save(self) -> None:
        self.memory.put("open", [t.record() for t in self.tasks.values() if t.open])
        self.memory.put("ids", [self.next_id, self.next_schedule])

    def save_schedules(self) -> None:
        self.memory.put("schedules", [s.record() for s in self.schedules.values()])
        self.memory.put("ids", [self.next_id, self.next_schedule])

    def save_service(self) -> None:
        self.memory.put("out_of_service", sorted(self.out_of_service))

    def recent(self, robot: str, limit: int) -> list[dict]:
        """Finished tasks, newest first (of ``robot`` when given)."""
        picked = [r for r in reversed(self.history) if not robot or r["assigned"] == robot]
        return picked[:max(0, limit)] if limit > 0 else picked

    def queued(self) -> list[Task]:
        """Queued tasks in the order they are handed out: priority, then age."""
        return sorted((t for t in self.tasks.values() if t.state == QUEUED),
                      key=lambda t: (-t.priority, t.id))

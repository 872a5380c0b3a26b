"""What a server that starts dispatching does with the running tasks of its copy (see
:mod:`.leader`): each goes on on its robot when the robot reports again, or fails (a task runs
at most once)."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable

from .board import Board
from .member import OFFLINE_AFTER
from .roster import Roster
from .tasks import FAILED, QUEUED, RUNNING, Task

log = logging.getLogger(__name__)


class TakeOver:
    """Settles the running tasks of a copied board; ``restart`` starts one again on its robot,
    ``publish`` publishes ``/fleet/tasks``."""

    def __init__(self, board: Board, roster: Roster, clock: Callable[[], float],
                 restart: Callable[[Task, str], None], publish: Callable[[], None],
                 name: str):
        self.board, self.roster, self.clock = board, roster, clock
        self.restart, self.publish, self.name = restart, publish, name

    async def settle_running(self) -> None:
        stale = self.roster.forget_times()  # none is free until it reports again
        running = [t for t in self.board.tasks.values() if t.state == RUNNING]
        for task in self.board.tasks.values():
            if task.state == QUEUED:
                task.reserved = ""
        self.publish()
        heard = await asyncio.gather(*(self._reports_again(name, msg) for name, msg in
                                       stale.items()))
        alive = {name for name, again in zip(stale, heard, strict=True) if again}
        for task in running:
            if task.state == RUNNING:
                self._resume(task, task.assigned in alive)

    async def _reports_again(self, robot: str, last: dict) -> bool:
        """Two reports after ``last`` within :data:`OFFLINE_AFTER` s: its server is alive (one
        could be the last its dead server sent, still on its way)."""
        for _ in range(2):
            msg = await self.roster.wait_member(robot, lambda m, old=last: m is not old,
                                                OFFLINE_AFTER)
            if msg is None:
                return False
            last = msg
        return True

    def _resume(self, task: Task, alive: bool) -> None:
        robot = task.assigned
        if alive:
            self.restart(task, robot)
            task.message = f"{robot} goes on (the dispatcher changed)"
            return
        task.state, task.finished = FAILED, self.clock()
        task.message = (f"{robot} went down with the dispatcher; not run again (a task runs "
                        "at most once)")
        log.warning("fleet: task %d: %s", task.id, task.message, extra={"ros_node": self.name})
        self.board.finished(task)

"""``/fleet/cancel``, ``/fleet/pause``, ``/fleet/resume`` (``CancelTask``), ``/fleet/history``
(``FleetHistory``) and ``/fleet/set_in_service`` (``SetInService``): a task's or a robot's
change on the board, answered as :mod:`..ground.acks` says (a change once it is kept)."""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from .board import Board
from .member import PKG
from .roster import Roster
from .tasks import CANCELLED, PAUSED, QUEUED, RUNNING, Refused, Task
from .traffic import Traffic


class TaskRequests:
    """The requests on the ``board``'s tasks and the ``roster``'s robots. Handed what they ask
    of the node: ``finish`` (a task ends), ``release`` (a robot's reserved tasks go to others),
    ``changed`` (kept and published), ``kick`` (look for work), ``serve``, and the bids of
    the dispatcher: ``offer`` (a resumed task) and ``offer_queued`` (every queued task, in the
    background, when a robot goes out of service or comes back): a low robot never takes a
    task there while a charged one is idle."""

    def __init__(self, board: Board, roster: Roster, traffic: Traffic, *,
                 finish: Callable[[Task, str, str], None],
                 release: Callable[[str], list[int]], changed: Callable[[], None],
                 kick: Callable[[], None], serve: Callable[..., None],
                 offer: Callable[[Task, str], Awaitable[None]],
                 offer_queued: Callable[[str], None]):
        self.board, self.roster, self.traffic = board, roster, traffic
        self.finish, self.release, self.changed, self.kick = finish, release, changed, kick
        self.offer, self.offer_queued = offer, offer_queued
        for name, kind, handler in (
                ("cancel", "CancelTask", self._cancel), ("pause", "CancelTask", self._pause),
                ("resume", "CancelTask", self._resume),
                ("history", "FleetHistory", self._history),
                ("set_in_service", "SetInService", self._set_in_service)):
            serve(f"/fleet/{name}", f"{PKG}/{kind}", handler)

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
        self.finish(task, CANCELLED, "cancelled")
        return {"success": True, "message": f"task {task.id} cancelled"}

    async def _pause(self, request: dict) -> dict:
        try:
            task = self._task(request)
            if task.state not in (QUEUED, RUNNING):
                raise Refused(f"task {task.id} is {task.state}, not queued or running")
        except Refused as exc:
            return {"success": False, "message": str(exc)}
        was = task.state
        task.state = PAUSED
        task.message = f"paused on its way: {task.assigned} stopped" if was == RUNNING else \
            "paused before it started"
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
        if not task.robot:  # offered again: the robot it had may be low now
            await self.offer(task, "resumed")
        self.kick()
        return {"success": True, "message": f"task {task.id} resumed"}

    async def _history(self, request: dict) -> dict:
        limit = int(request["limit"])
        return {"tasks": [Task.from_record(r).msg()
                          for r in self.board.recent(request["robot"], limit)]}

    async def _set_in_service(self, request: dict) -> dict:
        robot, serving = request["robot"], bool(request["in_service"])
        if robot not in self.roster.members:
            return {"success": False, "message": f"unknown robot '{robot}'"}
        if serving:
            self.board.out_of_service.discard(robot)
        else:
            self.board.out_of_service.add(robot)
        self.board.save_service()
        moved = self.release(robot) if not serving else []
        self.changed()
        self.offer_queued(f"{robot} is {'back in' if serving else 'out of'} service")
        self.kick()
        text = f"{robot} is {'in' if serving else 'out of'} service"
        if moved:
            text += f"; its queued tasks {', '.join(map(str, moved))} go to others"
        return {"success": True, "message": text}

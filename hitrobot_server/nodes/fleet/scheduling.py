"""``/fleet/schedule_add`` (``hitrobot_msgs/FleetScheduleAdd``), ``/fleet/schedule_list``
(``hitrobot_msgs/FleetScheduleList``), ``/fleet/schedule_remove`` (``hitrobot_msgs/CancelTask``:
its ``task`` is the schedule's id): recurring dispatches, kept in the state folder. A due slot
dispatches its task as ``/fleet/dispatch`` would (checked, bid for); slots missed while the
server was down run once at start (see :mod:`.schedules`)."""

from __future__ import annotations

import datetime as dt
import logging
from collections.abc import Awaitable, Callable

from ...bus.core import Bus
from .board import Board
from .member import OFFLINE, PKG
from .requests import read_stops
from .schedules import MAX_SCHEDULES, Schedule, ScheduleError, missed, parse, slot_after
from .tasks import Refused

log = logging.getLogger(__name__)

TASK_FIELDS = ("poi", "pose", "robot", "kind", "pois", "dwell", "laps", "priority")


class ScheduleServices:
    """The schedules on the ``board``; a due slot goes to ``dispatch`` (unless ``robots()``
    are all offline); ``serve`` is the fleet node's."""

    def __init__(self, board: Board, bus: Bus, clock: Callable[[], float],
                 robots: Callable[[], list[dict]], dispatch: Callable[[dict], Awaitable[dict]],
                 zone: dt.tzinfo, serve: Callable[..., None]):
        self.board, self.bus, self.clock, self.robots = board, bus, clock, robots
        self.dispatch, self.zone = dispatch, zone
        self._missed: dict[int, str] = {}  # schedule → what it missed (until its catch-up)
        for name, kind, handler in (("schedule_add", "FleetScheduleAdd", self._add),
                                    ("schedule_list", "FleetScheduleList", self._list),
                                    ("schedule_remove", "CancelTask", self._remove)):
            serve(f"/fleet/{name}", f"{PKG}/{kind}", handler)

    async def _add(self, request: dict) -> dict:
        try:
            parse(request["when"])
            self._check_room()
            task = {k: request[k] for k in TASK_FIELDS if k in request}
            await read_stops(self.bus, task)  # the targets are checked now
            self._check_room()  # again, with no await until it is applied: others came meanwhile
        except (ScheduleError, Refused) as exc:
            return {"success": False, "message": str(exc), "id": 0}
        now = self.clock()
        schedule = Schedule(self.board.next_schedule, request["when"].strip(), task, now)
        self.board.next_schedule += 1
        schedule.next = slot_after(schedule, now, self.zone)
        self.board.schedules[schedule.id] = schedule
        self.board.save_schedules()
        return {"success": True, "id": schedule.id, "message": f"schedule {schedule.id}: next "
                f"at {_local(schedule.next, self.zone)}"}

    def _check_room(self) -> None:
        if len(self.board.schedules) >= MAX_SCHEDULES:
            raise Refused(f"{MAX_SCHEDULES} schedules already; remove one first")

    async def _list(self, _request: dict) -> dict:
        return {"schedules": [s.msg() for s in self.board.schedules.values()]}

    async def _remove(self, request: dict) -> dict:
        if self.board.schedules.pop(request["task"], None) is None:
            return {"success": False, "message": f"no schedule {request['task']}"}
        self.board.save_schedules()
        return {"success": True, "message": f"schedule {request['task']} removed"}

    def catch_up(self) -> None:
        """At start: report the slots missed while the server was down; they run once."""
        now = self.clock()
        for schedule in self.board.schedules.values():
            count = missed(schedule, now, self.zone)
            if count:
                schedule.message = (f"missed {count} slot(s) while the server was down (from "
                                    f"{_local(schedule.next, self.zone)}); run once at start")
                log.warning("fleet: schedule %d %s", schedule.id, schedule.message)
                schedule.next = now  # fired by the first check once a robot is heard
                self._missed[schedule.id] = schedule.message

    async def fire_due(self) -> None:
        """Dispatch the due slots; none while no robot is heard from (a server starting, its
        robots not yet reporting: the slot waits for them rather than being refused). The
        node runs it beside its tick, so a hundred slots dispatching hold up no robot list."""
        now = self.clock()
        if all(r["state"] == OFFLINE for r in self.robots()):
            return
        due = [s for s in self.board.schedules.values() if s.next <= now]
        for schedule in due:  # all marked first: a check while these dispatch fires none again
            schedule.last = schedule.next
            schedule.next = slot_after(schedule, now, self.zone)
        for schedule in due:
            try:
                reply = await self.dispatch(dict(schedule.task))
            except Exception as exc:  # a slot never stops the schedules
                reply = {"accepted": False, "message": str(exc)}
            text = reply["message"] if reply["accepted"] else f"refused: {reply['message']}"
            schedule.message = f"{_local(schedule.last, self.zone)}: {text}"
            if missed_text := self._missed.pop(schedule.id, ""):
                schedule.message = f"{missed_text} — {schedule.message}"
        if due:
            self.board.save_schedules()


def _local(stamp: float, zone: dt.tzinfo) -> str:
    return dt.datetime.fromtimestamp(stamp, zone).strftime("%Y-%m-%d %H:%M %Z")

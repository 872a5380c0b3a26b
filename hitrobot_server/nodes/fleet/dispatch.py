"""Dispatch by cost: every capable robot bids its estimated finish time for the task (see
:mod:`.policy`); the reply says who won and why. A named robot is sent as asked. A target is
checked before it is accepted: finite, where a robot can stand on the map (the POIs' placement
rule) and reachable (each bidder plans it; a target no robot can reach is refused with the
planners' reasons). The charging policy lives here too:
a free robot below ``charge_below`` gets a ``charge`` task to its dock; robots sharing a dock
take turns."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Iterable, Mapping, Sequence

from ...bus.core import Bus
from ...bus.services import service_caller
from ...robot.model import Pose2D
from ..ground import messages as m
from .board import MAX_OPEN, Board
from .member import ERROR, OFFLINE
from .policy import Bid, Bidder, ChargePolicy, metres, winner
from .policy import bids as offers_for
from .requests import check_placed, read_stops
from .roster import Roster
from .runner import TaskRunner
from .tasks import CHARGE, QUEUED, RUNNING, Refused, Stop, Task
from .traffic import Traffic

BIDDING = "/bidding"
"""A task's reservation while robots bid for it (no robot is named so)."""
CHARGE_PRIORITY = 1000
"""A charge goes before any task waiting for the same robot."""
MAX_PER_CLIENT = 50
"""Open tasks one bridge client may have asked for (the board bounds them in all and per
robot)."""


def bidding(robots: Iterable[dict], exclude: Sequence[str] = (),
            held: Mapping[str, str] | None = None) -> tuple[list[dict], list[str]]:
    """The robots that bid for a task (heard from, not in error, in service, not ``exclude``,
    not ``held`` by another master's order) and, for the bids' reader, why each other one was
    skipped."""
    bidders, skipped = [], []
    held = held or {}
    for r in robots:
        name, state = r["name"], r["state"]
        why = ("offline" if state == OFFLINE else
               f"in error ({r.get('message') or 'no reason given'})" if state == ERROR else
               "out of service" if not r["in_service"] else
               held.get(name, "tried it already" if name in exclude else ""))
        if why:
            skipped.append(f"{name}: skipped, {why}")
        else:
            bidders.append(r)
    return bidders, skipped


class Dispatcher:
    """Takes a request to a task on the board, by the bids; hands out and charges.

    Handed the parts it reads (the board, the robots, the planners, the zones' traffic) and
    what it asks of the node: ``free`` (the robots that may start now), ``start_task``,
    ``kick`` (look for work) and ``publish`` (``/fleet/tasks``)."""

    def __init__(self, board: Board, roster: Roster, runner: TaskRunner, policy: ChargePolicy,
                 traffic: Traffic, bus: Bus, clock: Callable[[], float],
                 site_map: Callable[[], dict | None], *, free: Callable[[], list[dict]],
                 start_task: Callable[[Task, str], None], kick: Callable[[], None],
                 publish: Callable[[], None]):
        self.board, self.roster, self.runner, self.policy = board, roster, runner, policy
        self.traffic, self.bus, self.clock, self.site_map = traffic, bus, clock, site_map
        self.free, self.start_task, self.kick, self.publish = free, start_task, kick, publish
        self._accepting = asyncio.Lock()  # one request checked and queued at a time
        self._asked: dict[str, list[int]] = {}  # a bridge client → the tasks it asked for

    # ------------------------------------------------------------------ dispatch
    async def dispatch(self, request: dict) -> dict:
        """One request at a time (the queue's bounds hold under a burst, and a burst's
        requests wait their turn instead of all running between two turns of the loop)."""
        caller = service_caller()
        client = caller.node if caller is not None else ""
        async with self._accepting:
            try:
                task, text, start = await self.accept(request, client)
            except Refused as exc:
                return {"robot": "", "accepted": False, "message": str(exc), "task": 0}
            if client:
                self._asked.setdefault(client, []).append(task.id)
        if start:
            self.start_task(task, start)
        self.kick()
        return {"robot": start, "accepted": True, "task": task.id,
                "message": f"task {task.id}: {text}"}

    def _check_client(self, client: str) -> None:
        """Refuse a bridge client that has :data:`MAX_PER_CLIENT` open tasks already (a node
        or a schedule is bounded by the queue's own limits only)."""
        if not client:
            return
        tasks = self.board.tasks
        if len(self._asked) > MAX_OPEN:  # clients gone: only those with open tasks stay
            self._asked = {c: ids for c, ids in self._asked.items()
                           if any(i in tasks and tasks[i].open for i in ids)}
        ids = [i for i in self._asked.get(client, []) if i in tasks and tasks[i].open]
        self._asked[client] = ids
        if len(ids) >= MAX_PER_CLIENT:
            raise Refused(f"client {client} has {len(ids)} tasks queued or running; the limit "
                          f"per client is {MAX_PER_CLIENT}")

    async def accept(self, request: dict, client: str = "") -> tuple[Task, str, str]:
        """Check ``request`` (from bridge ``client``, if one), take the bids, queue the task:
        (task, why, robot started now)."""
        board = self.board
        robots = {r["name"]: r for r in self.roster.robots()}
        wanted = request.get("robot", "")
        if wanted and wanted not in robots:
            raise Refused(f"unknown robot '{wanted}' (robots: {', '.join(robots) or 'none'})")
        if not robots or all(r["state"] == OFFLINE for r in robots.values()):
            raise Refused("every robot is offline")
        if wanted and robots[wanted]["state"] == OFFLINE:
            raise Refused(f"robot '{wanted}' is offline")
        if wanted in self.roster.vda:
            raise Refused(f"robot '{wanted}' is {self.roster.vda[wanted]}")
        board.check_room(wanted)
        kind, stops, laps = await read_stops(self.bus, request)
        for stop in stops:
            check_placed(self.site_map(), stop)
            self.traffic.check_stop(stop)
        self._check_client(client)
        priority = max(-100, min(100, int(request.get("priority") or 0)))
        task = Task(0, kind, stops, wanted, priority, laps, created=self.clock())
        bidders, skipped = (([robots[wanted]], []) if wanted
                            else bidding(robots.values(), held=self.roster.vda))
        offers, refusals = await self.bids(task, bidders)
        if not offers:
            raise Refused("no robot can take it: " + ("; ".join(refusals + skipped) or
                                                       "every robot is out of service"))
        best = winner(offers)
        task.id = board.new_id()
        why = self._why(offers, skipped)
        free = {r["name"] for r in self.free()}
        board.add(task)
        if best.charge:
            self.charge(best.robot, f"task {task.id} needs more than its battery")
        if best.robot in free and not best.charge:
            return task, f"{best.robot} is on its way — bids: {why}", best.robot
        task.reserved = best.robot
        task.message = f"queued for {best.robot} " + (
            "(asked for)" if wanted else "(finishes first)") + f" — bids: {why}"
        self.changed()
        return task, task.message, ""

    def _why(self, offers: list[Bid], skipped: list[str]) -> str:
        """The bids, best first, then the robots that did not bid and why."""
        return "; ".join([*(b.why(self.policy) for b in sorted(offers, key=lambda b: b.finish)),
                          *skipped])

    async def rebid(self, task: Task) -> None:
        """A task that failed on a robot: the others bid again (once, on that event)."""
        await self.offer(task, task.message, exclude=task.tried,
                         none="no other robot can take it")

    async def offer(self, task: Task, note: str, exclude: Sequence[str] = (),
                    none: str = "no robot can take it") -> None:
        """Offer a queued task again (one the operator gave no robot), saying ``note`` first:
        the robots in service but ``exclude`` bid, the charging rule in every bid
        (``ChargePolicy.charges_first``), and the winner reserves it; one that charges first
        is sent to charge. The one decision of a re-offer after a failure, a resumed task and
        a robot back in or out of service, as of a first dispatch (a schedule's too) in
        :meth:`accept`."""
        robots, skipped = bidding(self.roster.robots(), exclude, self.roster.vda)
        task.reserved = BIDDING  # no robot takes it while the others bid
        offers, refusals = await self.bids(task, robots)
        task.reserved = ""
        if task.state != QUEUED or task.robot:  # paused or cancelled meanwhile
            return
        if not offers:
            task.message = f"{note}; {none}: " + ("; ".join(refusals + skipped) or
                                                 "every robot is out of service")
        else:
            best = winner(offers)
            task.reserved = best.robot
            task.message = f"{note}; queued for {best.robot} — bids: " \
                f"{self._why(offers, skipped)}"
            if best.charge:
                self.charge(best.robot, f"task {task.id} needs more than its battery")
        self.changed()
        self.kick()

    async def offer_queued(self, note: str) -> None:
        """Every queued task no robot was named for, offered again, one after the other (a
        robot came back into service or went out of it: the bids changed)."""
        ids = [t.id for t in self.board.queued() if not t.robot and t.kind != CHARGE
               and t.reserved != BIDDING]
        for task_id in ids:
            task = self.board.tasks.get(task_id)
            if task is not None and task.state == QUEUED and task.reserved != BIDDING:
                await self.offer(task, note)

    def changed(self) -> None:
        """A task changed: kept, and the list published."""
        self.board.save()
        self.publish()

    async def bids(self, task: Task, robots: list[dict]) -> tuple[list[Bid], list[str]]:
        """Each robot's bid (those that can plan the first leg) and why the others cannot:
        the plans, then :func:`.policy.bids` on a snapshot of the robots."""
        plans = await asyncio.gather(*(self.runner.plan(
            r["name"], task.target(), self._end_of_work(r["name"])) for r in robots))
        bidders = [Bidder(r["name"], r["battery"], self._busy_seconds(r["name"]),
                          self._charging(r)) for r in robots]
        return offers_for(task, bidders, plans, self.policy)

    def _charging(self, robot: dict) -> bool:
        """A charge task open for it: a charge not finished (a robot merely resting on its
        dock is not charging by the policy)."""
        return any(t.kind == CHARGE and t.open and robot["name"] in (t.robot, t.assigned)
                   for t in self.board.tasks.values())

    def _work(self, robot: str) -> list[Task]:
        return [t for t in self.board.tasks.values() if t.open and (
            t.assigned == robot and t.state == RUNNING or t.state == QUEUED and
            robot in (t.reserved, t.robot))]

    def _end_of_work(self, robot: str) -> Pose2D | None:
        """Where the robot will be once its work is done (None: where it is now)."""
        work = self._work(robot)
        return work[-1].route[-1].pose if work else None

    def _busy_seconds(self, robot: str) -> float:
        policy = self.policy
        msg = self.roster.last(robot)
        here = msg.get("pose", {}).get("position", {"x": 0.0, "y": 0.0})
        at, total = (here["x"], here["y"]), 0.0
        for task in self._work(robot):
            route = task.route[task.leg:]
            total += metres(route, at) / policy.speed + sum(s.dwell for s in route)
            if route:
                at = (route[-1].pose.x, route[-1].pose.y)
        return total

    # ------------------------------------------------------------------ handing out
    def next_for(self, robot: dict) -> Task | None:
        """The task ``robot`` (free) starts now, if any: its charge first; nothing else while
        the charging rule says it charges first (``ChargePolicy.charges_first``, the rule of
        every bid: below the threshold, a charge not finished, a task its battery would not
        last); a task reserved for another robot is left to it."""
        name, board = robot["name"], self.board
        for task in board.queued():
            if task.robot not in ("", name) or task.reserved not in ("", name):
                continue
            if task.kind == CHARGE:
                if not self._dock_taken(robot):
                    return task
                task.message = f"{name} waits for its dock"
                continue
            here = robot.get("pose", {}).get("position", {"x": 0.0, "y": 0.0})
            bidder = Bidder(name, robot["battery"], 0.0, self._charging(robot))
            if self.policy.charges_first(bidder, metres(task.route[task.leg:],
                                                        (here["x"], here["y"]))):
                continue
            return task
        return None

    def _dock_taken(self, robot: dict) -> bool:
        """Another robot is charging at (or going to) ``robot``'s dock."""
        dock = robot["dock"]["position"]
        for other in self.roster.robots():
            if other["name"] == robot["name"]:
                continue
            their = other["dock"]["position"]
            same = math.hypot(their["x"] - dock["x"], their["y"] - dock["y"]) < 0.3
            if same and any(t.kind == CHARGE and t.state == RUNNING and
                            t.assigned == other["name"] for t in self.board.tasks.values()):
                return True
        return False

    def charge_policy(self) -> None:
        """A free robot below the threshold, with a dock and no charge open, gets one."""
        below = self.policy.charge_below
        for robot in self.free():
            if robot["battery"] < below and robot["has_dock"] and robot["state"] != "charging":
                self.charge(robot["name"], f"battery {robot['battery']:.0f} % is below "
                            f"{below:.0f} %")

    def charge(self, robot: str, why: str) -> None:
        board = self.board
        if any(t.kind == CHARGE and t.open and t.robot == robot for t in board.tasks.values()):
            return
        msg = self.roster.last(robot)
        dock = m.pose2d(msg["dock"]) if msg.get("has_dock") else Pose2D(0, 0, 0)
        task = Task(board.new_id(), CHARGE, [Stop("dock", dock)], robot, CHARGE_PRIORITY,
                    created=self.clock(), message=f"to charge: {why}")
        board.add(task)
        self.publish()

    def release(self, robot: str) -> list[int]:
        """A robot out of service: its reserved tasks wait for the others (re-bid when handed
        out); the ones asked of it by name stay."""
        moved = []
        for task in self.board.queued():
            if task.reserved == robot and not task.robot:
                task.reserved, task.message = "", f"{robot} is out of service; waiting for " \
                    "another robot"
                moved.append(task.id)
        return moved


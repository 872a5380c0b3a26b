"""One queue per site across the servers of a Zenoh bus: one server's fleet node dispatches,
the others follow.

Without a link to other servers (the default bus) the fleet node always dispatches and nothing
here runs: a single server behaves as it always did. Over ``--bus zenoh`` every server's fleet
node takes part in the bus's ``fleet`` group (:class:`~hitrobot_server.bus.link.Group`: a live
dispatcher is kept; with none, the live server with the smallest Zenoh id claims):

* **The dispatcher** offers the ``/fleet/*`` services, publishes ``/fleet/robots`` and
  ``/fleet/tasks``, hands out tasks and fires the schedules. Every change of its board is copied
  to the followers (:mod:`.replica`). Any ``/fleet/*`` change is acknowledged (the table of
  :mod:`..ground.acks`, as on a single server) once it is in the dispatcher's site folder and
  applied (and on disk) at every live follower (the board's ``durable``), so whichever takes
  over has it; when one does not answer within
  :data:`~.replica.REPLICA_TIMEOUT` s the reply says how many have it. A task is handed to
  a robot only once its assignment (running, on that robot) is on disk and copied the same way:
  the record that keeps a take-over from running it twice.
* **A follower** offers nothing of its own: a ``/fleet/*`` call from its clients misses locally
  and goes to the dispatcher over the bus (the link's proxy of its service), and its clients get
  the dispatcher's ``/fleet/tasks``. It keeps the copy of the board in its own site folder and
  hears the robots, ready to take over.
* **Take-over** (the dispatcher's server killed: its tokens go with it): the follower that
  claims continues from its copy. Queued tasks stay queued (their bids are dropped: the free
  robots take them). No robot counts as free until it reports again. A running task whose robot
  reports twice more (each within :data:`~.member.OFFLINE_AFTER` s) continues on that robot
  from the leg it was on; one whose robot does not (it went down with the dispatcher) fails
  with that reason — it is never started again elsewhere, so a task id runs at most once.
  No task is handed out (and a dispatch is queued, not started) until that is settled.
* **A restart**: a server that finds a dispatcher follows it and takes its board in place of
  its own folder's. One that claims at its start with open tasks in its folder hands none out
  for :data:`RESTART_SETTLE` s, in case a dispatcher shows up (then it follows and its queue is
  replaced; two dispatchers that meet keep the earlier claim).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable, Coroutine, Hashable
from typing import Any

from ...bus.core import Bus
from ...bus.link import Group
from .board import Board
from .replica import Replica
from .takeover import TakeOver

log = logging.getLogger(__name__)

RESTART_SETTLE = 5.0
"""Seconds a server that claims at its start, with open tasks from its own folder, waits before
it hands any out: its links to the others may still be coming up (Zenoh retries a connection
every 1 to 4 s), and a dispatcher among them would make its folder's queue a stale one."""

Handler = Callable[[dict], Awaitable[dict]]


class Leadership:
    """Whether this server's fleet node dispatches; its offers follow the role.

    Handed the bus and the offers' ``owner`` and node ``name`` (what the bus files them
    under), the board it copies, ``spawn`` (the node's tasks), the :class:`.TakeOver` it runs
    when this server starts dispatching and ``took_over`` (the node's: the copy applies)."""

    def __init__(self, bus: Bus, owner: Hashable, name: str, group: Group | None, board: Board,
                 spawn: Callable[[Coroutine[Any, Any, Any]], asyncio.Task],
                 take_over: TakeOver, took_over: Callable[[], None]):
        self.bus, self.owner, self.name, self.group = bus, owner, name, group
        self.board, self.spawn = board, spawn
        self.take_over, self.took_over = take_over, took_over
        self.leading = group is None  # no link: always
        self.leader = ""
        self.taking_over = False  # no task is handed out until the running ones are settled
        self.assigning = self.leading
        """Tasks may be handed out: this server dispatches and is not taking over."""
        self._term = 0  # counts this server's turns as dispatcher
        self._followed = False  # a dispatcher's board was taken in this run
        self._role_changed = asyncio.Event()
        # the board's changes go to the followers
        self.replica = Replica(board, group) if group is not None else None
        self._services: dict[str, tuple[str, Handler]] = {}
        self._topics: dict[str, tuple[str, bool]] = {}

    def _set(self, leading: bool, taking_over: bool) -> None:
        self.leading, self.taking_over = leading, taking_over
        self.assigning = leading and not taking_over

    # ------------------------------------------------------------------ what a leader offers
    def service(self, name: str, type_name: str, handler: Handler) -> None:
        self._services[name] = (type_name, handler)
        if self.leading:
            self._offer_service(name)

    def advertise(self, topic: str, type_name: str, latch: bool) -> None:
        self._topics[topic] = (type_name, latch)
        if self.leading:
            self._offer_topic(topic)

    def _offer_service(self, name: str) -> None:
        type_name, handler = self._services[name]
        self.bus.advertise_service(name, type_name, self.owner, self.name, handler)

    def _offer_topic(self, topic: str) -> None:
        type_name, latch = self._topics[topic]
        self.bus.advertise(topic, type_name, self.owner, self.name, latch=latch)

    def _offer(self, leading: bool) -> None:
        for topic in self._topics:
            if leading:
                self._offer_topic(topic)
            else:
                self.bus.unadvertise(topic, self.owner)
        for name in self._services:
            if leading:
                self._offer_service(name)
            else:
                self.bus.unadvertise_service(name, self.owner)

    # ------------------------------------------------------------------ the group's member
    async def join(self) -> None:
        if self.group is None or self.replica is None:
            return
        self.spawn(self.replica.send_loop())
        await self.group.join(self)

    async def leave(self) -> None:
        if self.group is not None:
            await self.group.leave()

    def role(self, leader: str) -> None:
        assert self.group is not None and self.replica is not None
        was, self.leader = self.leading, leader
        self._set(leader == self.group.me, self.taking_over)
        self.replica.lead(self.leading)
        self._role_changed.set()
        log.info("fleet: %s", "this server dispatches" if self.leading else
                 f"following the dispatcher {leader[:8]}" if leader else "no dispatcher yet",
                 extra={"ros_node": self.name})
        if self.leading != was:
            self._offer(self.leading)
        if was and not self.leading:  # two dispatchers met: this one's robots stop
            for task in self.board.tasks.values():
                if task.goal is not None:
                    task.goal.cancel()
        if self.leading and not was:
            self._set(True, True)
            self._term += 1
            self.spawn(self._take_over(self._term))
        elif leader and not self.leading:
            self._followed = True
            self.replica.follow()

    async def apply(self, payload: bytes) -> None:
        assert self.replica is not None
        await self.replica.apply(payload)

    def snapshot(self) -> bytes:
        assert self.replica is not None
        return self.replica.snapshot()

    # ------------------------------------------------------------------ take-over
    async def _take_over(self, term: int) -> None:
        """Continue the queue from the copy (see the module's docstring)."""
        try:
            if not self._followed and any(t.open for t in self.board.tasks.values()):
                self._role_changed.clear()  # a stale queue unless no dispatcher shows up
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._role_changed.wait(), RESTART_SETTLE)
            if term == self._term and self.leading:
                await self.take_over.settle_running()
        finally:
            if term == self._term:
                self._set(self.leading, False)
        if term == self._term and self.leading:
            self.took_over()

"""The site's queue copied from the dispatching server to the others (``--bus zenoh``).

Every change of the board (a put of one of its sections) is sent, in order and with a sequence
number, as the open tasks, the ids, the schedules, the robots out of service and the finished
tasks added to the history since the last change; a follower applies it to its board and to its
own site folder, and answers once that is on disk. A follower that joins, follows a new leader
or finds a change missing (its base is not the follower's last) fetches the leader's whole
board instead. Changes are coalesced: one send at a time, each carrying everything put since
the last.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Coroutine
from typing import Any

import orjson

from ...bus.link import Group
from .board import HISTORY, KEEP_FINISHED, Board
from .schedules import Schedule
from .tasks import Task
from .zoning import SECTION as ZONES

log = logging.getLogger(__name__)

REPLICA_TIMEOUT = 2.0
"""Seconds the followers have to apply one change."""

Sent = tuple[int, int]  # (followers that applied a change, followers asked)


class Replica:
    """The board's changes sent to the followers (leading) or applied from the leader; it
    listens to the board's change signal and is one of what the board's ``durable`` awaits."""

    def __init__(self, board: Board, group: Group):
        self.board, self.group = board, group
        board.on_change(self.changed)
        board.copied_by(self.copied)
        self.seq = 0  # the last change sent (leading) or applied (following)
        self.leading = False
        self._next: asyncio.Future[Sent] | None = None  # the send that carries the puts so far
        self._in_flight: asyncio.Future[Sent] | None = None
        self._last: Sent = (0, 0)  # how the last send went
        self._wake: asyncio.Event | None = None
        self._history_sent = -1  # id of the last history record sent (-1: send it whole)
        self._fetching: asyncio.Task | None = None

    # ------------------------------------------------------------------ leading
    def changed(self) -> None:
        if not self.leading or self._wake is None:
            return
        if self._next is None:
            self._next = asyncio.get_running_loop().create_future()
        self._wake.set()

    async def send_loop(self) -> None:
        """Send the changes, one at a time (run by the node while it lives)."""
        self._wake = asyncio.Event()
        while True:
            await self._wake.wait()
            self._wake.clear()
            future, self._next = self._next, None
            if future is None or not self.leading:
                continue
            self._in_flight = future
            try:
                sent = await self.group.replicate(self._change(), REPLICA_TIMEOUT)
            except Exception as exc:  # the network: counted as not replicated
                log.warning("fleet: the queue was not copied to the other servers: %s", exc)
                sent = (0, 1)
            future.set_result(sent)
            self._last = sent
            if self._in_flight is future:
                self._in_flight = None

    def pending(self) -> asyncio.Future[Sent]:
        """The send that carries every change so far: (followers that applied it, followers
        asked); done already when they were all sent."""
        future = self._next or self._in_flight
        if future is None:
            future = asyncio.get_running_loop().create_future()
            future.set_result(self._last)
        return future

    def copied(self) -> Coroutine[Any, Any, str]:
        """Awaits the send carrying every change so far (taken now): "" when every follower
        applied it, else how many did."""
        return _said(self.pending())

    def lead(self, leading: bool) -> None:
        self.leading = leading
        self._history_sent = -1
        self._last = (0, 0)

    def _change(self) -> bytes:
        self.seq += 1
        history = self.board.history
        added = _after(history, self._history_sent)
        self._history_sent = history[-1]["id"] if history else -1
        change: dict[str, Any] = {"seq": self.seq, "base": self.seq - 1,
                                  "sections": sections(self.board)}
        if added is None:
            change["history"] = history
        else:
            change["history_add"] = added
        return orjson.dumps(change)

    def snapshot(self) -> bytes:
        return orjson.dumps({"seq": self.seq, "base": None, "sections": sections(self.board),
                             "history": self.board.history})

    # ------------------------------------------------------------------ following
    def follow(self) -> None:
        """A new leader: its whole board first."""
        self.seq = 0
        self.catch_up()

    def catch_up(self) -> None:
        if self._fetching is None or self._fetching.done():
            self._fetching = asyncio.ensure_future(self._fetch())

    async def _fetch(self) -> None:
        try:
            await self.apply(await self.group.fetch(REPLICA_TIMEOUT))
        except Exception as exc:
            log.warning("fleet: could not read the dispatching server's queue: %s", exc)

    async def apply(self, payload: bytes) -> None:
        """One change (or the whole board) from the leader, kept on disk before it returns."""
        change = orjson.loads(payload)
        if change["seq"] <= self.seq and change["base"] is not None:
            return  # already applied (it came with a whole board)
        if change["base"] is not None and change["base"] != self.seq:
            self.catch_up()  # a change was missed: the whole board
            return
        _apply(self.board, change)
        self.seq = int(change["seq"])
        await self.board.memory.durable()


async def _said(sent: asyncio.Future[Sent]) -> str:
    acks, asked = await asyncio.shield(sent)
    if acks < asked:  # whichever follower takes over must have it: all of them
        return f" (copied to {acks} of the {asked} other servers only)"
    return ""


def sections(board: Board) -> dict[str, Any]:
    return {"open": [t.record() for t in board.tasks.values() if t.open],
            "ids": [board.next_id, board.next_schedule],
            "schedules": [s.record() for s in board.schedules.values()],
            "out_of_service": sorted(board.out_of_service),
            "zones": board.memory.get(ZONES) or []}


def _after(history: list[dict], last: int) -> list[dict] | None:
    """The records after the one of task ``last`` (None: not found, send all)."""
    if last < 0:
        return None
    for i in range(len(history) - 1, -1, -1):
        if history[i]["id"] == last:
            return history[i + 1:]
    return None


def _apply(board: Board, change: dict) -> None:
    """Replace the board's state with the leader's; its site folder gets it too."""
    s = change["sections"]
    opened = [Task.from_record(r) for r in s["open"]]
    schedules = [Schedule.from_record(r) for r in s["schedules"]]
    if "history" in change:
        history = list(change["history"])
    else:
        history = [*board.history, *change["history_add"]]
    board.history = history[-HISTORY:]
    finished = [Task.from_record(r) for r in board.history[-KEEP_FINISHED:]]
    board.tasks = {t.id: t for t in sorted([*finished, *opened], key=lambda t: t.id)}
    board.schedules = {sc.id: sc for sc in schedules}
    board.out_of_service = {str(r) for r in s["out_of_service"]}
    board.next_id, board.next_schedule = (int(i) for i in s["ids"])
    board.memory.put("history", board.history)
    board.memory.put(ZONES, list(s.get("zones", [])))  # the traffic takes them on taking over
    board.save()
    board.save_schedules()
    board.save_service()

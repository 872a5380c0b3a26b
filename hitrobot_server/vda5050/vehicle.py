"""One robot as a VDA 5050 vehicle, without the transport: messages in (``receive``), messages
out through the ``send`` it is handed; the order driven node by node over the bus; the state
sent on every change the spec lists, at most every ``MIN_STATE_INTERVAL`` s, at least every
``STATE_INTERVAL`` s; visualization while it drives."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from collections.abc import Callable

from ..bus.core import Bus
from ..robot.capabilities import Robot
from . import errors as e
from . import messages as msgs
from .actions import Actions
from .driver import ARRIVED, STOPPED, TAKEN, Driver
from .inbox import Inbox
from .orders import OrderBook, Refused, check_order, key
from .reader import read

log = logging.getLogger(__name__)

Send = Callable[[str, dict, bool], None]
"""``send(subtopic, message, retain)``: queued on the vehicle's link, never blocking."""
MAX_PENDING = 8
"""Orders waiting for a fresh reading of the robot; more are refused."""
READ_DRIVING, READ_IDLE = 0.25, 1.0
"""Seconds between two readings of the robot while an order runs, and otherwise."""


class Vehicle:
    """A robot's VDA 5050 side: order book, actions, driver, what it sends."""

    def __init__(self, bus: Bus, robot: Robot, name: str, *, manufacturer: str, serial: str,
                 map_frame: str, map_id: Callable[[], str],
                 problem: Callable[[float, float], str | None], send: Send):
        self.robot, self.name, self.serial = robot, name, serial
        self.map_id, self.problem, self.send = map_id, problem, send
        self.book = OrderBook()
        self.inbox = Inbox(manufacturer, serial)
        self.headers = msgs.Headers(manufacturer, serial)
        self.driver = Driver(bus, name, map_frame)
        self.reading = msgs.Reading()
        self.actions = Actions(self.book, self.driver, lambda: self.reading, self.changed,
                               map_id)
        self.actions.cancel_order, self.actions.pause = self.cancel_order, self.pause
        self.actions.send_state = lambda: self.changed(now=True)
        self.actions.send_factsheet = self.send_factsheet
        self.fleet_task = 0  # the fleet task this robot runs (0: none), heard on the bus
        self.motion_running = False  # some motion runs on the robot, ours or not
        self.ignored: set[str] = set()  # kinds of ignored messages logged once
        self.on_change: Callable[[], None] = lambda: None  # the link's line on the bus
        self._dirty = asyncio.Event()
        self._read_at = 0.0  # loop time the last reading of the robot began
        self._order_turn = asyncio.Lock()  # orders read the robot afresh one at a time
        self._pending = 0
        self._later: set[asyncio.Task] = set()
        self._drive: asyncio.Task | None = None
        self._report: asyncio.Task | None = None

    # ------------------------------------------------------------------ life
    def online(self) -> None:
        """The link is up: say so, the factsheet, a state."""
        self.send("connection", msgs.connection(self.headers, time.time(), msgs.ONLINE), True)
        self.send_factsheet()
        self.changed(now=True)

    def start(self) -> None:
        self._report = asyncio.get_running_loop().create_task(self._reporting())

    async def stop(self) -> None:
        self.driver.close()
        self.actions.close()
        for task in (self._drive, self._report):
            if task is not None:
                task.cancel()
        for task in self._later:
            task.cancel()
        await asyncio.gather(*(t for t in (self._drive, self._report) if t is not None),
                             *self._later, return_exceptions=True)

    def offline_message(self, state: str) -> dict:
        return msgs.connection(self.headers, time.time(), state)

    def send_factsheet(self) -> None:
        self.send("factsheet", msgs.factsheet(self.headers, time.time(), "hitrobot-slamware"),
                  True)

    # ------------------------------------------------------------------ messages in
    def receive(self, topic: str, payload: bytes) -> None:
        verdict = self.inbox.take(topic, payload)
        if verdict.ignored:
            kind = f"{topic} {verdict.kind}"
            if kind not in self.ignored:
                self.ignored.add(kind)
                log.warning("vda5050 %s: ignored %s (logged once)", self.serial,
                            verdict.ignored)
            return
        if verdict.error is not None:
            self.book.refuse(verdict.error)
            self.changed()
            return
        if topic == "order":
            self._order(verdict.message)
        else:
            for action in verdict.message["actions"]:
                self.actions.instant(action)

    def other_work(self) -> str | None:
        """Who else drives the robot now: a fleet task, or a motion not ours."""
        if self.fleet_task:
            return f"the robot runs fleet task {self.fleet_task}"
        if self.motion_running and self.driver.goal is None and not self.book.active \
                and self._read_at > self.driver.ended_at:
            return "the robot runs a motion from another client (the console or a goal)"
        return None

    def _order(self, order: dict) -> None:
        """Take an order now; while some motion seemed to run at the last reading (or orders
        wait already), after a fresh reading, in arrival order."""
        if self._pending >= MAX_PENDING:
            self.book.refuse(e.order_error(e.ORDER, f"{MAX_PENDING} orders wait already",
                                           order))
            self.changed()
        elif self._pending or self.motion_running:
            self._pending += 1
            task = asyncio.get_running_loop().create_task(self._order_later(order))
            self._later.add(task)
            task.add_done_callback(self._later.discard)
        else:
            self._take(order)

    async def _order_later(self, order: dict) -> None:
        try:
            async with self._order_turn:
                await self._read()
                self._take(order)
        finally:
            self._pending -= 1

    def _take(self, order: dict) -> None:
        try:
            busy = self.other_work()
            if busy and order["orderId"] != self.book.order_id:
                raise Refused(e.order_error(e.ORDER, f"order refused: {busy}", order))
            check_order(order, self.map_id(), self.problem)
            taken = self.book.receive(order, self._distance)
        except Refused as refused:
            self.book.refuse(refused.error)
            self.changed()
            return
        if taken == "repeat":
            return
        if taken == "new":
            self.book.due += self.book.reached(order["nodes"][0])
        self.changed()
        self._kick()

    def _distance(self, node: dict) -> float:
        p = node["nodePosition"]
        return math.hypot(p["x"] - self.reading.x, p["y"] - self.reading.y)

    # ------------------------------------------------------------------ driving
    def _kick(self) -> None:
        if self._drive is None or self._drive.done():
            self._drive = asyncio.get_running_loop().create_task(self._driving())

    async def _driving(self) -> None:
        while True:
            due, self.book.due = self.book.due, []
            if due:
                await self.actions.on_node(due)
                continue
            node = self.book.next_node()
            if node is None:
                return
            outcome = await self.driver.go(node["nodePosition"])
            if outcome.kind == ARRIVED and self.book.nodes and key(self.book.nodes[0]) == key(node):
                self.book.due += self.book.reached(node)
                self.changed()
            elif outcome.kind == STOPPED:
                return  # a pause or a cancel: they say what happens next
            elif outcome.kind != ARRIVED:
                self._lost(node, outcome.kind, outcome.reason)
                return

    def _lost(self, node: dict, kind: str, reason: str) -> None:
        """The drive to ``node`` ended by someone else or by the robot: the order is over."""
        order = {"orderId": self.book.order_id, "orderUpdateId": self.book.update_id}
        if kind == TAKEN:
            error = e.order_error(e.ORDER_CANCELLED, f"the order was cancelled on the robot "
                                  f"(console or another client): {reason}", order,
                                  nodeId=node["nodeId"])
        else:
            error = e.order_error(e.NO_ROUTE, f"node {node['nodeId']} not reached: {reason}",
                                  order, nodeId=node["nodeId"])
        self.book.cancel(error["errorDescription"])
        self.book.errors.add(error)
        self.changed()

    def cancel_order(self) -> asyncio.Future | None:
        """``cancelOrder``: stop the drive (the book is halted meanwhile); the future ends once
        the robot stopped."""
        self.book.halted = True
        self.driver.stop()
        return self._drive if self._drive is not None and not self._drive.done() else None

    def pause(self, paused: bool) -> None:
        self.book.paused = paused
        if paused:
            self.driver.stop()
        else:
            self._kick()

    # ------------------------------------------------------------------ messages out
    def changed(self, now: bool = False) -> None:
        """Something the state shows changed: a state goes out within ``MIN_STATE_INTERVAL``."""
        self._dirty.set()
        self.on_change()

    async def _reporting(self) -> None:
        loop = asyncio.get_running_loop()
        sent = read_at = shown_at = 0.0
        while True:
            period = READ_DRIVING if self.book.active else READ_IDLE
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._dirty.wait(), period)
            now = loop.time()
            if now - read_at >= period:
                read_at = now
                await self._read()
            due = self._dirty.is_set() or now - sent >= msgs.STATE_INTERVAL
            if due:
                self._dirty.clear()
                self.send("state", msgs.state(self.headers, time.time(), self.book,
                                              self.reading, self.map_id()), False)
                sent = now
                self.on_change()
            if self.reading.driving and now - shown_at >= msgs.VISUALIZATION_INTERVAL:
                self.send("visualization", msgs.visualization(
                    self.headers, time.time(), self.reading, self.map_id()), False)
                shown_at = now
            if due:  # the factsheet's minStateInterval between two states
                await asyncio.sleep(msgs.MIN_STATE_INTERVAL)

    async def _read(self) -> None:
        before = self.reading
        started = asyncio.get_running_loop().time()
        self.reading, faults, self.motion_running = await read(self.robot, before)
        self._read_at = started
        changed = False
        for kind in (e.ROBOT, e.LOCALIZATION):
            changed |= self.book.errors.replace(kind, [f for f in faults
                                                       if f["errorType"] == kind])
        r = self.reading
        if changed or (round(before.battery), before.charging, before.driving, before.online,
                       before.localized, before.e_stop) != (
                round(r.battery), r.charging, r.driving, r.online, r.localized, r.e_stop):
            self._dirty.set()

    def status(self) -> dict:
        """What the bus's link line shows of this vehicle."""
        last = self.book.errors.items[-1]["errorDescription"] if self.book.errors.items else ""
        return {"order_id": self.book.order_id, "order_update_id": self.book.update_id,
                "active": self.book.active, "paused": self.book.paused, "last_error": last}

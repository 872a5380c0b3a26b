"""Running VDA 5050 actions, instant or on a node: each goes WAITING → RUNNING → FINISHED or
FAILED in the order book, with an error naming it when it fails."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

from . import errors as e
from .driver import Driver
from .messages import Reading
from .orders import FAILED, FINISHED, RUNNING, OrderBook, parameters

DOCK_TIMEOUT = 600.0
"""Seconds the robot has to reach its dock and start charging."""
WAIT_STEP = 0.25
LONG_RUNNING = 4
"""Long instant actions (initPosition, startCharging) running at once; more fail at once."""


class Actions:
    """The actions of one vehicle, run against its driver and reported in its book."""

    def __init__(self, book: OrderBook, driver: Driver, reading: Callable[[], Reading],
                 changed: Callable[[], None], map_id: Callable[[], str]):
        self.book, self.driver, self.reading = book, driver, reading
        self.changed, self.map_id = changed, map_id
        self.long: set[asyncio.Task] = set()
        # the vehicle's own answers to these (it owns the drive and the messages)
        self.cancel_order: Callable[[], asyncio.Future | None] = lambda: None
        self.pause: Callable[[bool], None] = lambda paused: None
        self.send_state: Callable[[], None] = lambda: None
        self.send_factsheet: Callable[[], None] = lambda: None

    def end(self, action: dict, status: str, result: str = "", scope: str = "instant") -> None:
        self.book.set_action(action["actionId"], status, result)
        if status == FAILED and result:
            kind = e.INSTANT_ACTION if scope == "instant" else e.ORDER_ACTION
            self.book.errors.add(e.error(kind, f"{action['actionType']}: {result}",
                                         topic="instantActions" if scope == "instant" else
                                         "order", actionId=action["actionId"],
                                         actionType=action["actionType"]))
        self.changed()

    # ------------------------------------------------------------------ instant actions
    def instant(self, action: dict) -> None:
        """One instant action, begun now (a long one goes on in a task)."""
        self.book.add_instant(action)
        kind = action["actionType"]
        if kind == "cancelOrder":
            self._cancel(action)
        elif kind in ("startPause", "stopPause"):
            self.pause(kind == "startPause")
            self.end(action, FINISHED, "paused" if kind == "startPause" else "resumed")
        elif kind == "stateRequest":
            self.end(action, FINISHED)
            self.send_state()
        elif kind == "factsheetRequest":
            self.send_factsheet()
            self.end(action, FINISHED)
        elif kind == "stopCharging":
            self.end(action, FINISHED, "charging ends when the robot leaves its dock")
        elif kind in ("initPosition", "startCharging"):
            if len(self.long) >= LONG_RUNNING:
                self.end(action, FAILED, f"{LONG_RUNNING} long actions already run")
                return
            run = self._init_position if kind == "initPosition" else self.charge
            task = asyncio.get_running_loop().create_task(run(action))
            self.long.add(task)
            task.add_done_callback(self.long.discard)
        else:
            self.end(action, FAILED, f"{kind!r} is not an instant action this vehicle runs")

    def _cancel(self, action: dict) -> None:
        if not self.book.active:
            self.book.set_action(action["actionId"], FAILED, "no order to cancel")
            self.book.errors.add(e.error(e.NO_ORDER_TO_CANCEL, "cancelOrder: there is no "
                                         "order to cancel", topic="instantActions",
                                         actionId=action["actionId"]))
            self.changed()
            return
        self.book.set_action(action["actionId"], RUNNING)
        self.changed()
        stopped = self.cancel_order()

        async def finish() -> None:
            if stopped is not None:
                await asyncio.gather(stopped, return_exceptions=True)
            # nothing ahead and cancelOrder FINISHED in one state, as a master expects them
            self.book.cancel("cancelled by cancelOrder")
            self.book.halted = self.book.paused = False
            self.end(action, FINISHED, "order cancelled")

        task = asyncio.get_running_loop().create_task(finish())
        self.long.add(task)
        task.add_done_callback(self.long.discard)

    async def _init_position(self, action: dict) -> None:
        given = parameters(action)
        try:
            x, y, theta = (float(given[k]) for k in ("x", "y", "theta"))
        except (KeyError, TypeError, ValueError):
            self.end(action, FAILED, "parameters x, y and theta (numbers) are needed")
            return
        if not all(map(math.isfinite, (x, y, theta))):
            self.end(action, FAILED, "x, y and theta must be finite")
            return
        if "mapId" in given and given["mapId"] != self.map_id():
            self.end(action, FAILED, f"mapId {given['mapId']!r} is not the robot's map "
                     f"{self.map_id()!r}")
            return
        if self.book.driving_base:
            self.end(action, FAILED, "not while an order drives the robot")
            return
        self.book.set_action(action["actionId"], RUNNING)
        self.changed()
        done, why = await self.driver.relocalize(x, y, theta)
        if done and isinstance(given.get("lastNodeId"), str):
            self.book.set_last_node(given["lastNodeId"])
        if done:
            self.book.errors.clear(e.LOCALIZATION)
        self.end(action, FINISHED if done else FAILED, why)

    # ------------------------------------------------------------------ on a node, or instant
    async def charge(self, action: dict, scope: str = "instant") -> None:
        """``startCharging``: the robot's go-home, finished once it charges on its dock."""
        self.book.set_action(action["actionId"], RUNNING)
        self.changed()
        self.driver.go_home()
        loop = asyncio.get_running_loop()
        deadline = loop.time() + DOCK_TIMEOUT
        while not self.reading().charging:
            if self.book.actions.get(action["actionId"], {}).get("actionStatus") != RUNNING:
                return  # cancelled meanwhile
            if loop.time() > deadline:
                self.end(action, FAILED, f"not charging after {DOCK_TIMEOUT:.0f} s", scope)
                return
            await asyncio.sleep(WAIT_STEP)
        self.end(action, FINISHED, "charging", scope)

    async def on_node(self, actions: list[dict]) -> None:
        """A node's actions, one after the other (each blocks the drive on)."""
        for action in actions:
            if self.book.actions.get(action["actionId"], {}).get("actionStatus") != "WAITING":
                continue  # cancelled meanwhile
            if action["actionType"] == "startCharging":
                await self.charge(action, "order")
            else:  # stopCharging (check_order lets no other through)
                self.end(action, FINISHED, "charging ends when the robot leaves its dock",
                         "order")

    def close(self) -> None:
        for task in self.long:
            task.cancel()

"""The robots the fleet hears on ``/fleet/members``: the last report of each, when it came,
and a wait for the next; the ``/fleet/robots`` list is made from them and the board."""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Callable

from .board import Board
from .member import CHARGING, IDLE, MOVING, OFFLINE, OFFLINE_AFTER
from .policy import ChargePolicy
from .tasks import RUNNING


class Roster:
    """Each robot's last report; the board says which task it runs and whether it serves."""

    def __init__(self, board: Board, policy: ChargePolicy):
        self.board, self.policy = board, policy
        self.members: dict[str, tuple[float, dict]] = {}  # name → (heard at, FleetRobot)
        self._heard: dict[str, asyncio.Event] = {}
        self._placed: set[str] = set()  # robots whose pose was reported once
        self.vda: dict[str, str] = {}  # robot → the VDA 5050 order it runs, and whose

    def heard(self, msg: dict) -> bool:
        """A robot's report; True when it changes what the robot may take (its state, or its
        battery crossing the charge threshold)."""
        name = msg["name"]
        before = self.members.get(name, (0.0, {}))[1]
        if msg["state"] == OFFLINE and "pose" in before:  # it reports no pose: where it was
            msg = {**msg, "pose": before["pose"]}
        elif msg["state"] != OFFLINE:
            self._placed.add(name)
        self.members[name] = (time.monotonic(), msg)
        heard = self._heard.pop(name, None)
        if heard is not None:
            heard.set()
        return (before.get("state") != msg["state"]
                or self.low(before.get("battery", 100.0)) != self.low(msg["battery"]))

    def low(self, battery: float) -> bool:
        return battery < self.policy.charge_below

    def last(self, robot: str) -> dict:
        """The robot's last report ({} when never heard)."""
        return self.members.get(robot, (0.0, {}))[1]

    def pose_of(self, robot: str) -> tuple[float, float] | None:
        """Where the robot was last seen; an offline robot stays where it was (it still
        stands there), one never seen anywhere is nowhere (not at the origin)."""
        msg = self.members.get(robot, (0.0, None))[1]
        if msg is None or robot not in self._placed:
            return None
        p = msg["pose"]["position"]
        return float(p["x"]), float(p["y"])

    def unplace(self, robot: str) -> None:
        """Where the robot was is no longer known (an operator says it is not there): it has
        no pose until it reports one again."""
        self._placed.discard(robot)

    def forget_times(self) -> dict[str, dict]:
        """Every robot counts as not heard (a take-over: none is free until it reports again);
        the last reports."""
        stale = {name: msg for name, (_heard, msg) in self.members.items()}
        for name, msg in stale.items():
            self.members[name] = (0.0, msg)
        return stale

    async def wait_member(self, robot: str, done: Callable[[dict], bool],
                          timeout: float) -> dict | None:
        """The robot's first report for which ``done`` holds; None after ``timeout`` s."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            msg = self.members.get(robot, (0.0, None))[1]
            if msg is not None and done(msg):
                return msg
            left = deadline - loop.time()
            if left <= 0:
                return None
            event = self._heard.setdefault(robot, asyncio.Event())
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(event.wait(), min(left, 3600.0))

    def vda_orders(self, links: list[dict]) -> None:
        """``/vda5050/link``: the robots a master control's order drives now are busy."""
        self.vda = {link["robot"]: f"busy with VDA 5050 order {link['order_id']} of the "
                    f"master control at {link['broker']}" for link in links if link["active"]}

    def robots(self) -> list[dict]:
        """The ``/fleet/robots`` list: each robot's report, its task, whether it serves."""
        now = time.monotonic()
        running = {t.assigned: t.id for t in self.board.tasks.values() if t.state == RUNNING}
        out = []
        for name in sorted(self.members):
            heard, msg = self.members[name]
            msg = dict(msg, task=running.get(name, 0),
                       in_service=name not in self.board.out_of_service)
            if now - heard > OFFLINE_AFTER:
                msg.update(state=OFFLINE, message=f"not heard from for {now - heard:.0f} s")
            elif name in self.vda and msg["state"] in (IDLE, CHARGING, MOVING):
                msg.update(state=MOVING, message=self.vda[name])  # not free: no fleet task
            out.append(msg)
        return out

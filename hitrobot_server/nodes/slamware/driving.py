"""The robot's drive lease on the bus (the logic is :mod:`..ground.drive_lease`): asked per
velocity command, published latched on ``/drive_lease``, timed to lapse, ended by its
holder's disconnect (its client node leaving, seen among ``Bus.watchers``), taken over on
``/drive_lease/take``.

When a lease ends while its holder was still moving the robot, the robot gets one stop: a zero
``Twist`` the node publishes on its own velocity topic, so every subscriber (and a recording)
sees it, and which the velocity handler carries out as a stop of manual driving only.
"""

from __future__ import annotations

import asyncio
import time

from ...bus.services import service_caller
from ...bus.topics import Message, Origin, RequestRejected, Topic
from ..base import RobotNode, require_finite
from ..ground.drive_lease import Change, DriveLease, Verdict, driver_name, may_take_over

LEASE_TOPIC = "/drive_lease"
TAKE_SERVICE = "/drive_lease/take"
LEASE_TYPE = "hitrobot_msgs/DriveLease"
NAMES = (LEASE_TOPIC, TAKE_SERVICE)
"""What the lease adds to the Slamware node's names (under /NAME/ on a fleet)."""
ZERO = {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}


class Driving:
    """One robot's lease, wired to its node: ``stop_topic`` is where its stop is published."""

    def __init__(self, node: RobotNode, stop_topic: str, authenticate: bool = False):
        self.node, self.stop_topic, self.authenticate = node, stop_topic, authenticate
        self.lease = DriveLease(time.monotonic)
        self.stopping = False  # True while the lease's own stop is being published
        self._timer: asyncio.TimerHandle | None = None
        self._guarded: Topic | None = None
        node.advertise(LEASE_TOPIC, LEASE_TYPE, latch=True)
        node.service(TAKE_SERVICE, "std_srvs/Trigger", self._take)
        node.bus.watchers.append(self._graph_changed)
        self._publish(Change(None, None, ""))

    def guard(self, topic: Topic) -> None:
        """Refuse another's command on ``topic`` (the node's velocity topic, subscribed)
        before anyone sees it: no subscriber, recording or peer takes a refused command for
        one that moved the robot."""
        topic.guard = self._guard
        self._guarded = topic

    def _guard(self, message: Message) -> None:
        self.verdict(message.origin, moving(message.msg))

    def close(self) -> None:
        """The node stops: no more timing or listening."""
        if self._timer is not None:
            self._timer.cancel()
        if self._guarded is not None and self._guarded.guard == self._guard:
            self._guarded.guard = None
        if self._graph_changed in self.node.bus.watchers:
            self.node.bus.watchers.remove(self._graph_changed)

    def verdict(self, origin: Origin | None, moving: bool) -> Verdict:
        """What to do with a velocity command from ``origin``; another's while the lease is
        held is refused here, naming the holder. The server's own commands (``origin`` None)
        take no lease: its stop is a stop of manual driving, its moves are its own."""
        if origin is None:
            return Verdict.IDLE_STOP if self.stopping or not moving else Verdict.DRIVE
        self._expire()
        verdict, change = self.lease.ask(origin.node, driver_name(origin), moving)
        if verdict is Verdict.REFUSE:
            holder = self.lease.holder
            assert holder is not None
            raise RequestRejected(
                f"cmd_vel: the robot is driven by {holder.name}; yours was refused (the lease "
                f"lapses {self.lease.lapse:g} s after their last command; an admin may take it "
                f"over with {self.node.bus.node_name(TAKE_SERVICE)})")
        if change is not None:
            self._publish(change)
        self._arm()
        return verdict

    # ------------------------------------------------------------------ lease changes
    def _arm(self) -> None:
        due = self.lease.due()
        if due is None or self._timer is not None:
            return
        loop = asyncio.get_running_loop()
        self._timer = loop.call_later(max(0.0, due - time.monotonic()), self._on_timer)

    def _on_timer(self) -> None:
        self._timer = None
        self._expire()
        self._arm()  # renewed meanwhile: wait for the new time

    def _expire(self) -> None:
        change = self.lease.expire()
        if change is not None:
            self._publish(change)

    def _graph_changed(self, kind: str, name: str) -> None:
        """A node that went (a client's session ends) gives its lease back."""
        if kind == "node" and self.lease.driving(name) and name not in self.node.bus.nodes:
            change = self.lease.leave(name)
            if change is not None:
                self._publish(change)

    async def _take(self, request: dict) -> dict:
        origin = service_caller()
        if origin is None:
            return {"success": False, "message": "only a client can take the drive lease"}
        if not may_take_over(origin, self.authenticate):
            return {"success": False, "message": f"only an admin may take the drive lease "
                                                 f"over (yours: {origin.auth_level or 'none'})"}
        self._expire()
        change = self.lease.take(origin.node, driver_name(origin))
        if change.reason != "already held":
            self._publish(change)
        self._arm()
        previous = change.previous.name if change.previous else "nobody"
        return {"success": True, "message": f"{driver_name(origin)} holds the drive lease "
                                            f"(from {previous}); drive within "
                                            f"{self.lease.lapse:g} s to keep it"}

    def _publish(self, change: Change) -> None:
        """The lease's state on its topic; then, if its driver was moving the robot, the
        stop."""
        holder = change.holder
        since = time.time() - (time.monotonic() - holder.since) if holder else 0.0
        self.node.publish(LEASE_TOPIC, {
            "holder": holder.name if holder else "",
            "since": since,
            "previous": change.previous.name if change.previous else "",
            "reason": change.reason,
            "stopped": change.stop,
        })
        if change.stop:
            self._stop()

    def _stop(self) -> None:
        self.stopping = True
        try:
            self.node.publish(self.stop_topic, ZERO)
        finally:
            self.stopping = False


def moving(twist: dict) -> bool:
    """Whether a ``Twist`` moves the robot (a stop does not); NaN and infinities are
    refused, naming the field."""
    linear, angular = twist["linear"]["x"], twist["angular"]["z"]
    require_finite("linear.x", linear)
    require_finite("angular.z", angular)
    return linear != 0 or angular != 0

"""The hidden services and topics ROS 2 gives every action, wired to the bus action.

A ROS 2 action ``/x`` is, on the graph, the services ``/x/_action/send_goal``,
``/x/_action/cancel_goal`` and ``/x/_action/get_result`` and the topics ``/x/_action/status``
and ``/x/_action/feedback``. Clients use them directly (roslibjs 2.x ``cancelAllGoals`` calls
``cancel_goal``), so every action on the bus gets them while it is advertised. They see every
goal of the action, also the ones sent with the protocol's ``send_action_goal``.
"""

from __future__ import annotations

import asyncio
import logging
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any, Protocol

from ..types.convert import default_message
from ..types.registry import TypeRegistry
from .clock import ros_time
from .errors import BusError
from .services import (
    ACTIVE_STATUSES,
    STATUS_UNKNOWN,
    Action,
    GoalHandle,
    GoalOutcome,
    ServiceHandler,
)
from .topics import Message, Topic

log = logging.getLogger(__name__)

KEEP_FINISHED = 64
"""Finished goals whose result ``get_result`` still answers (and ``status`` still lists)."""

# action_msgs/CancelGoal return codes
CANCEL_NONE, CANCEL_REJECTED, CANCEL_UNKNOWN_GOAL, CANCEL_TERMINATED = 0, 1, 2, 3
ZERO_UUID = bytes(16)


def _seconds(stamp: dict) -> float:
    return stamp["secs"] + stamp["nsecs"] * 1e-9


def hidden_names(action: str, atype: str) -> tuple[dict[str, str], dict[str, str]]:
    """The services and topics (name -> type) ROS 2 gives the action ``action``."""
    prefix = f"{action}/_action"
    services = {
        f"{prefix}/send_goal": f"{atype}_SendGoal",
        f"{prefix}/cancel_goal": "action_msgs/CancelGoal",
        f"{prefix}/get_result": f"{atype}_GetResult",
    }
    topics = {
        f"{prefix}/status": "action_msgs/GoalStatusArray",
        f"{prefix}/feedback": f"{atype}_FeedbackMessage",
    }
    return services, topics


class ActionBus(Protocol):
    """What the hidden interfaces use of the bus that makes them (``core.Bus``, not imported:
    the bus imports this module)."""

    types: TypeRegistry

    def advertise_service(self, name: str, type_name: str, owner: Hashable, node: str,
                          handler: ServiceHandler) -> Any: ...

    def unadvertise_service(self, name: str, owner: Hashable) -> bool: ...

    def advertise(self, name: str, type_name: str | None, owner: Hashable, node: str,
                  latch: bool = False) -> Topic: ...

    def unadvertise(self, name: str, owner: Hashable) -> None: ...

    def topic(self, name: str) -> Topic | None: ...

    def publish(self, name: str, msg: dict) -> Message: ...

    def start_goal(self, name: str, goal: dict, on_feedback: Callable[[dict], None] | None = None,
                   goal_uuid: bytes | None = None) -> tuple[GoalHandle, Any]: ...


class ActionInterfaces:
    """``<action>/_action/*`` for one bus action; :meth:`close` removes them again."""

    def __init__(self, bus: ActionBus, action: Action):
        self.bus = bus
        self.action = action
        self.prefix = f"{action.name}/_action"
        self.status_topic = f"{self.prefix}/status"
        self.feedback_topic = f"{self.prefix}/feedback"
        self.goals: OrderedDict[bytes, GoalHandle] = OrderedDict()
        self.outcomes: dict[bytes, GoalOutcome] = {}
        self._waiters: dict[bytes, list[asyncio.Future]] = {}
        self._services: list[str] = []
        services, topics = hidden_names(action.name, action.type_name)
        handlers = (self._send_goal, self._cancel_goal, self._get_result)
        for (name, stype), handler in zip(services.items(), handlers, strict=True):
            try:
                bus.advertise_service(name, stype, self, action.node, handler)
            except BusError as exc:  # e.g. a client already serves that name
                log.warning("action %s: %s not offered: %s", action.name, name, exc)
                continue
            self._services.append(name)
        bus.advertise(self.status_topic, topics[self.status_topic], self, action.node,
                      latch=True)
        bus.advertise(self.feedback_topic, topics[self.feedback_topic], self, action.node)
        action.watchers.append(self)

    def close(self) -> None:
        if self in self.action.watchers:
            self.action.watchers.remove(self)
        for name in self._services:
            self.bus.unadvertise_service(name, self)
        self.bus.unadvertise(self.status_topic, self)
        self.bus.unadvertise(self.feedback_topic, self)
        for futures in self._waiters.values():
            for fut in futures:
                if not fut.done():
                    fut.set_exception(BusError(f"action '{self.action.name}' went away"))
        self._waiters.clear()

    # ------------------------------------------------------------- watching goals
    def goal_status(self, handle: GoalHandle) -> None:
        if handle.uuid not in self.goals:
            self.goals[handle.uuid] = handle
            self._forget_old()
        self._publish_status()

    def goal_feedback(self, handle: GoalHandle, values: dict) -> None:
        topic = self.bus.topic(self.feedback_topic)
        if topic is not None and topic.subscribers:
            self.bus.publish(self.feedback_topic,
                             {"goal_id": {"uuid": handle.uuid}, "feedback": values})

    def goal_finished(self, handle: GoalHandle, outcome: GoalOutcome) -> None:
        self.goals[handle.uuid] = handle
        self.outcomes[handle.uuid] = outcome
        for fut in self._waiters.pop(handle.uuid, []):
            if not fut.done():
                fut.set_result(outcome)
        self._forget_old()
        self._publish_status()

    def _forget_old(self) -> None:
        finished = [u for u, h in self.goals.items() if h.status not in ACTIVE_STATUSES]
        for uuid in finished[: max(0, len(finished) - KEEP_FINISHED)]:
            del self.goals[uuid]
            self.outcomes.pop(uuid, None)

    def _info(self, handle: GoalHandle) -> dict:
        return {"goal_id": {"uuid": handle.uuid}, "stamp": ros_time(handle.accepted_at)}

    def _publish_status(self) -> None:
        self.bus.publish(self.status_topic, {"status_list": [
            {"goal_info": self._info(h), "status": h.status} for h in self.goals.values()]})

    # ------------------------------------------------------------- services
    async def _send_goal(self, request: dict) -> dict:
        uuid = bytes(request["goal_id"]["uuid"])
        known = self.goals.get(uuid)
        if known is not None and known.status in ACTIVE_STATUSES:
            return {"accepted": False, "stamp": ros_time(0.0)}
        handle, _task = self.bus.start_goal(self.action.name, request["goal"], goal_uuid=uuid)
        return {"accepted": True, "stamp": ros_time(handle.accepted_at)}

    async def _cancel_goal(self, request: dict) -> dict:
        info = request["goal_info"]
        uuid = bytes(info["goal_id"]["uuid"])
        before = _seconds(info["stamp"])
        if uuid != ZERO_UUID:
            handle = self.goals.get(uuid)
            if handle is None:
                return {"return_code": CANCEL_UNKNOWN_GOAL, "goals_canceling": []}
            if handle.status not in ACTIVE_STATUSES and not before:
                return {"return_code": CANCEL_TERMINATED, "goals_canceling": []}
        chosen = [h for h in self.goals.values() if h.status in ACTIVE_STATUSES and (
            h.uuid == uuid or (uuid == ZERO_UUID and not before) or
            (before and h.accepted_at <= before))]
        for handle in chosen:
            handle.cancel()
        return {"return_code": CANCEL_NONE if chosen else CANCEL_REJECTED,
                "goals_canceling": [self._info(h) for h in chosen]}

    async def _get_result(self, request: dict) -> dict:
        uuid = bytes(request["goal_id"]["uuid"])
        handle = self.goals.get(uuid)
        if handle is None:
            return {"status": STATUS_UNKNOWN, "result": self._empty_result()}
        outcome = self.outcomes.get(uuid)
        if outcome is None:
            fut = asyncio.get_running_loop().create_future()
            self._waiters.setdefault(uuid, []).append(fut)
            try:
                outcome = await fut
            finally:
                waiting = self._waiters.get(uuid)
                if waiting and fut in waiting:
                    waiting.remove(fut)
        values = outcome.values if isinstance(outcome.values, dict) else self._empty_result()
        return {"status": outcome.status, "result": values}

    def _empty_result(self) -> dict:
        return default_message(self.action.atype.result, self.bus.types)

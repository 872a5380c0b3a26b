"""Local actions served to other processes in ROS 2's shape: the ``send_goal``, ``get_result``
and ``cancel_goal`` services under ``<action>/_action/`` and the ``feedback`` topic."""

from __future__ import annotations

import asyncio
import contextlib
import time
from typing import Any

import orjson
import zenoh

from ..errors import ServiceError
from ..services import GoalHandle, GoalOutcome
from .peer import Peer
from .services import Entry, ServiceBridge

PARTS = ("send_goal", "get_result", "cancel_goal")
Goals = dict[bytes, tuple[GoalHandle, asyncio.Task]]  # goal id -> the goal and its run


class ActionServer:
    """Keeps each local action's queryables and feedback publisher in step with the bus."""

    def __init__(self, peer: Peer, services: ServiceBridge):
        self.peer = peer
        self.services = services
        self._goals: Goals = {}  # goals other processes sent
        self._feedback_pubs: dict[str, Any] = {}

    def sync(self, name: str) -> None:
        action = self.peer.bus.actions.get(name)
        old = self._feedback_pubs.pop(name, None)
        if old is not None:
            with contextlib.suppress(zenoh.ZError):
                old.undeclare()
        if action is None:
            gone = [(f"{name}/_action/{p}", "", None) for p in PARTS]
            self.services.serve(name, gone if self.services.serving(name) else [], None)
            return
        parts = self.peer.codec.action_parts(action.atype)
        feedback = parts["feedback"]
        feedback_key = self.peer.key(
            f"{name}/_action/feedback", feedback, self.peer.codec.type_hash(feedback)
        )
        publisher = self._feedback_pubs[name] = self.peer.session.declare_publisher(feedback_key)
        served = ServedAction(self.peer, self._goals, name, action.atype, parts, publisher)
        self.services.serve(name, served.entries(), action.node)

    def stop(self) -> None:
        for _handle, task in list(self._goals.values()):
            task.cancel()


class ServedAction:
    """One local action's three services, as another process's queries reach them."""

    def __init__(
        self, peer: Peer, goals: Goals, name: str, atype: Any, parts: dict[str, str],
        publisher: Any,
    ):
        self.peer = peer
        self.codec = peer.codec
        self.goals = goals
        self.name = name
        self.atype = atype
        self.parts = parts  # the interface types, from codec.action_parts
        self.publisher = publisher  # the feedback topic's

    def entries(self) -> list[Entry]:
        parts, name = self.parts, self.name
        return [
            (f"{name}/_action/send_goal", parts["send_goal"], self.send_goal),
            (f"{name}/_action/get_result", parts["get_result"], self.get_result),
            (f"{name}/_action/cancel_goal", parts["cancel_goal"], self.cancel_goal),
        ]

    async def send_goal(self, payload: bytes) -> bytes:
        codec, parts, atype = self.codec, self.parts, self.atype
        req = codec.decode_raw(payload, f"{parts['send_goal']}_Request")
        goal_id = bytes(req.goal_id.uuid)
        goal = codec.unwrap(req.goal, atype.goal)

        def on_feedback(values: dict) -> None:
            fb = codec.make(
                parts["feedback"],
                goal_id=req.goal_id,
                feedback=codec.wrap(values, atype.feedback),
            )
            self.publisher.put(codec.encode_raw(fb, parts["feedback"]))

        handle, task = self.peer.bus.start_goal(self.name, goal, on_feedback)
        self.goals[goal_id] = (handle, task)
        task.add_done_callback(
            lambda _t: self.peer.loop.call_later(60, self.goals.pop, goal_id, None)
        )
        sec, nsec = divmod(time.time_ns(), 1_000_000_000)
        stamp = codec.make("builtin_interfaces/msg/Time", sec=sec, nanosec=nsec)
        resp = codec.make(f"{parts['send_goal']}_Response", accepted=True, stamp=stamp)
        return codec.encode_raw(resp, f"{parts['send_goal']}_Response")

    async def get_result(self, payload: bytes) -> bytes:
        codec, parts = self.codec, self.parts
        req = codec.decode_raw(payload, f"{parts['get_result']}_Request")
        found = self.goals.get(bytes(req.goal_id.uuid))
        if found is None:
            raise ServiceError(f"action '{self.name}': unknown goal")
        out: GoalOutcome = await asyncio.shield(found[1])
        if isinstance(out.values, str):
            raise ServiceError(orjson.dumps({"status": out.status, "text": out.values}).decode())
        resp = codec.make(
            f"{parts['get_result']}_Response",
            status=out.status,
            result=codec.wrap(out.values, self.atype.result),
        )
        return codec.encode_raw(resp, f"{parts['get_result']}_Response")

    async def cancel_goal(self, payload: bytes) -> bytes:
        codec = self.codec
        req = codec.decode_raw(payload, "action_msgs/srv/CancelGoal_Request")
        found = self.goals.get(bytes(req.goal_info.goal_id.uuid))
        if found is not None:
            found[0].cancel()
        resp = codec.make(
            "action_msgs/srv/CancelGoal_Response",
            return_code=0 if found is not None else 2,
            goals_canceling=[req.goal_info] if found is not None else [],
        )
        return codec.encode_raw(resp, "action_msgs/srv/CancelGoal_Response")

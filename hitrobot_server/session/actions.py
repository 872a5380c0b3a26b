"""ROS 2 action ops (roslibjs 2.x ``ROSLIB.Action``, roslibpy's ``ActionClient``)."""

from __future__ import annotations

import asyncio
import itertools
from typing import TYPE_CHECKING, Any

from ..bus.errors import ActionError
from ..bus.names import canonical, valid_name
from ..bus.services import (
    STATUS_ABORTED,
    STATUS_UNKNOWN,
    GoalHandle,
    GoalOutcome,
)
from ..protocol.errors import ProtocolError
from ..types.convert import ConversionError, from_json
from .services import args_to_request, split_id, too_many_in_flight

if TYPE_CHECKING:
    from .session import Session


class ActionOps:
    def __init__(self, session: Session):
        self.session = session
        self.goals: dict[Any, GoalHandle] = {}  # goals this client sent, by its id
        self.provided: set[str] = set()
        self.serving: dict[str, tuple[asyncio.Future, GoalHandle]] = {}  # goals we were handed
        self._counters: dict[str, itertools.count] = {}

    # ------------------------------------------------------------- client side
    def send_action_goal(self, msg: dict) -> None:
        s = self.session
        action_str, op_id = split_id(msg["action"], msg.get("id"))
        name = canonical(action_str)
        base = {"action": msg["action"]}
        if op_id is not None:
            base["id"] = op_id

        def fail(text: str) -> None:
            s.send(
                {
                    "op": "action_result",
                    **base,
                    "values": text,
                    "status": STATUS_UNKNOWN,
                    "result": False,
                }
            )
            s.status("error", f"send_action_goal: {text}", op_id)

        limit = s.settings.max_requests_in_flight
        if len(self.goals) >= limit:
            fail(too_many_in_flight(limit, "action goals"))
            return
        action = s.bus.action(name)
        if action is None:
            fail(f"action '{name}' does not exist")
            return
        wanted = msg.get("action_type")
        if wanted:
            try:
                if s.types.action(wanted).name != action.atype.name:
                    fail(
                        f"action '{name}' has type '{s.types.short(action.type_name)}', "
                        f"not '{wanted}'"
                    )
                    return
            except LookupError as exc:
                fail(str(exc.args[0] if exc.args else exc))
                return
        try:
            goal = args_to_request("send_action_goal", action.atype.goal, msg.get("args"), s, op_id)
        except ProtocolError as exc:
            fail(exc.msg.removeprefix("send_action_goal: "))
            return
        if op_id is not None and op_id in self.goals:
            raise ProtocolError(
                f"send_action_goal: a goal with id {op_id!r} is still running", op_id
            )
        want_feedback = bool(msg.get("feedback", False))
        frag = s.fragment_size(msg)

        def on_feedback(values: dict) -> None:
            if want_feedback:
                s.send({"op": "action_feedback", **base, "values": values}, fragment_size=frag)

        s.bus.client_called("send_action_goal", name, s.origin)
        try:
            handle, task = s.bus.start_goal(name, goal, on_feedback)
        except ActionError as exc:
            fail(str(exc))
            return
        key = op_id if op_id is not None else handle.goal_id
        self.goals[key] = handle

        def done(t: asyncio.Task) -> None:
            self.goals.pop(key, None)
            if t.cancelled():
                return
            out: GoalOutcome = t.result()
            s.send(
                {
                    "op": "action_result",
                    **base,
                    "values": out.values,
                    "status": out.status,
                    "result": out.result,
                },
                fragment_size=frag,
            )

        task.add_done_callback(done)

    def cancel_action_goal(self, msg: dict) -> None:
        handle = self.goals.get(msg["id"])
        if handle is None:
            raise ProtocolError(
                f"cancel_action_goal: no running goal with id {msg['id']!r}", msg["id"]
            )
        handle.cancel()
        self.session.status("info", f"cancel requested for goal {msg['id']!r}", msg["id"])

    # ------------------------------------------------------------- provider side
    def advertise_action(self, msg: dict) -> None:
        s = self.session
        action_str = msg["action"]
        if not valid_name(action_str):
            raise ProtocolError(
                f"advertise_action: field 'action' is not a valid name: {action_str!r}",
                msg.get("id"),
            )
        name = canonical(action_str)
        counter = self._counters.setdefault(name, itertools.count(1))
        type_name = msg["type"]

        async def handler(handle: GoalHandle) -> GoalOutcome:
            gid = f"action_goal:{name}:{next(counter)}"
            fut = asyncio.get_running_loop().create_future()
            self.serving[gid] = (fut, handle)
            handle.on_cancel.append(
                lambda: s.send({"op": "cancel_action_goal", "id": gid, "action": name})
            )
            s.send(
                {
                    "op": "send_action_goal",
                    "id": gid,
                    "action": name,
                    "action_type": type_name,
                    "args": handle.goal,
                    "feedback": True,
                }
            )
            try:
                return await fut
            finally:
                self.serving.pop(gid, None)

        s.bus.advertise_action(name, type_name, s, s.node, handler, client=True)
        self.provided.add(name)
        s.status("info", f"advertised action '{name}'", msg.get("id"))

    def unadvertise_action(self, msg: dict) -> None:
        s = self.session
        name = canonical(msg["action"])
        if name not in self.provided or not s.bus.unadvertise_action(name, s):
            raise ProtocolError(
                f"unadvertise_action: action '{name}' is not advertised by you", msg.get("id")
            )
        self.provided.discard(name)
        self._fail_serving(name, f"action '{name}' was unadvertised")
        s.status("info", f"unadvertised action '{name}'", msg.get("id"))

    def _entry(self, op: str, msg: dict) -> tuple[asyncio.Future, GoalHandle]:
        entry = self.serving.get(msg["id"]) if isinstance(msg["id"], str) else None
        if entry is None:
            raise ProtocolError(f"{op}: no goal with id {msg['id']!r} was sent to you", msg["id"])
        return entry

    def action_feedback(self, msg: dict) -> None:
        _fut, handle = self._entry("action_feedback", msg)
        try:
            values, _ = from_json(handle.action.atype.feedback, msg["values"], self.session.types)
        except ConversionError as exc:
            raise ProtocolError(f"action_feedback: field 'values': {exc}", msg["id"]) from None
        handle.feedback(values)

    def action_result(self, msg: dict) -> None:
        fut, handle = self._entry("action_result", msg)
        if fut.done():
            return
        values = msg.get("values")
        if msg["result"]:
            try:
                values, _ = from_json(handle.action.atype.result, values or {}, self.session.types)
            except ConversionError as exc:
                fut.set_result(GoalOutcome(STATUS_ABORTED, f"invalid result: {exc}", False))
                raise ProtocolError(f"action_result: field 'values': {exc}", msg["id"]) from None
        elif not isinstance(values, str) or not values:
            values = f"goal failed (status {msg['status']})"
        fut.set_result(GoalOutcome(int(msg["status"]), values, bool(msg["result"])))

    def _fail_serving(self, name: str | None, text: str) -> None:
        for _gid, (fut, handle) in list(self.serving.items()):
            if (name is None or handle.action.name == name) and not fut.done():
                fut.set_result(GoalOutcome(STATUS_ABORTED, text, False))

    def close(self) -> None:
        for handle in list(self.goals.values()):
            handle.cancel()
        self.goals.clear()
        self._fail_serving(None, f"the action provider ({self.session.node}) disconnected")
        for name in list(self.provided):
            self.session.bus.unadvertise_action(name, self.session)
        self.provided.clear()

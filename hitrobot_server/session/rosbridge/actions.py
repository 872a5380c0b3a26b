"""ROS 2 action ops (roslibjs 2.x ``ROSLIB.Action``, roslibpy's ``ActionClient``)."""

from __future__ import annotations

import asyncio
import itertools
from typing import TYPE_CHECKING, Any

from ...bus.errors import ActionError
from ...bus.names import canonical, valid_name
from ...bus.services import (
    STATUS_ABORTED,
    STATUS_UNKNOWN,
    GoalHandle,
    GoalOutcome,
)
from ...protocol import ops
from ...protocol.errors import MessageId, ProtocolError
from ...protocol.ops import (
    ActionFeedback,
    ActionResult,
    AdvertiseAction,
    CancelActionGoal,
    SendActionGoal,
    UnadvertiseAction,
)
from ...types.convert import ConversionError, from_json
from ...types.generation import ros2_times
from .services import args_to_request, split_id, too_many_in_flight

if TYPE_CHECKING:
    from .context import OpContext


class ActionOps:
    def __init__(self, client: OpContext):
        self.client = client
        self.goals: dict[Any, GoalHandle] = {}  # goals this client sent, by its id
        self.cancel_on_close: set[GoalHandle] = set()  # those it asked to end with it
        self.provided: set[str] = set()
        self.serving: dict[str, tuple[asyncio.Future, GoalHandle]] = {}  # goals we were handed
        self._counters: dict[str, itertools.count] = {}

    # ------------------------------------------------------------- client side
    def send_action_goal(self, op: SendActionGoal) -> None:
        c = self.client
        action_str, op_id = split_id(op.action, op.id)
        name = canonical(action_str)

        def fail(text: str) -> None:
            c.send(ops.action_result(op.action, op_id, text, STATUS_UNKNOWN, False))
            c.status("error", f"send_action_goal: {text}", op_id)

        found = self._goal_of(op, name, op_id)
        if isinstance(found, str):
            fail(found)
            return
        if op_id is not None and op_id in self.goals:
            raise ProtocolError(
                f"send_action_goal: a goal with id {op_id!r} is still running", op_id
            )
        want_feedback = op.feedback
        frag = c.fragment_size(op)
        action = c.bus.action(name)
        assert action is not None  # (_goal_of found it)
        atype, types = action.atype, c.bus.types

        def on_feedback(values: dict) -> None:
            if want_feedback:  # a ROS 2 op: its times as ROS 2 spells them
                values = ros2_times(values, atype.feedback, types)
                c.send(ops.action_feedback(op.action, op_id, values), fragment_size=frag)

        c.bus.client_called("send_action_goal", name, c.origin)
        try:
            handle, task = c.bus.start_goal(name, found, on_feedback)
        except ActionError as exc:
            fail(str(exc))
            return
        key = op_id if op_id is not None else handle.goal_id
        self.goals[key] = handle
        handle.sent_as = key
        if op.cancel_on_disconnect:
            self.cancel_on_close.add(handle)

        def done(t: asyncio.Task) -> None:
            self.goals.pop(key, None)
            self.cancel_on_close.discard(handle)
            if t.cancelled():
                return
            out: GoalOutcome = t.result()
            values = ros2_times(out.values, atype.result, types) if out.result else out.values
            c.send(ops.action_result(op.action, op_id, values, out.status, out.result),
                   fragment_size=frag)

        task.add_done_callback(done)

    def _goal_of(self, op: SendActionGoal, name: str, op_id: MessageId) -> dict | str:
        """The goal to send, or why it is refused (the text of the failed result)."""
        c = self.client
        limit = c.settings.max_requests_in_flight
        if len(self.goals) >= limit:
            return too_many_in_flight(limit, "action goals")
        action = c.bus.action(name)
        if action is None:
            return f"action '{name}' does not exist"
        wanted = op.action_type
        if wanted:
            try:
                if c.bus.types.action(wanted).name != action.atype.name:
                    return (f"action '{name}' has type '{c.bus.types.short(action.type_name)}', "
                            f"not '{wanted}'")
            except LookupError as exc:
                return str(exc.args[0] if exc.args else exc)
        try:
            return args_to_request("send_action_goal", action.atype.goal, op.args, c, op_id)
        except ProtocolError as exc:
            return exc.msg.removeprefix("send_action_goal: ")

    def cancel_action_goal(self, op: CancelActionGoal) -> None:
        """Cancel a goal by its sender's id: this client's own first, else any client's (a
        goal outlives its sender's connection, so another may cancel it)."""
        handle = self.goals.get(op.id) or self._anyones(op.id)
        if handle is None:
            raise ProtocolError(f"cancel_action_goal: no running goal with id {op.id!r}", op.id)
        handle.cancel()
        self.client.status("info", f"cancel requested for goal {op.id!r}", op.id)

    def _anyones(self, goal_id: MessageId) -> GoalHandle | None:
        actions = self.client.bus.actions.values()
        return next((h for a in actions for h in a.goals.values()
                     if h.sent_as == goal_id and not h.cancelled.is_set()), None)

    # ------------------------------------------------------------- provider side
    def advertise_action(self, op: AdvertiseAction) -> None:
        c = self.client
        action_str = op.action
        if not valid_name(action_str):
            raise ProtocolError(
                f"advertise_action: field 'action' is not a valid name: {action_str!r}", op.id
            )
        name = canonical(action_str)
        counter = self._counters.setdefault(name, itertools.count(1))
        type_name = op.type

        async def handler(handle: GoalHandle) -> GoalOutcome:
            gid = f"action_goal:{name}:{next(counter)}"
            fut = asyncio.get_running_loop().create_future()
            self.serving[gid] = (fut, handle)
            handle.on_cancel.append(
                lambda: c.send(ops.cancel_action_goal(gid, name))
            )
            goal = ros2_times(handle.goal, handle.action.atype.goal, c.bus.types)
            c.send(ops.send_action_goal(gid, name, type_name, goal))
            try:
                return await fut
            finally:
                self.serving.pop(gid, None)

        c.bus.advertise_action(name, type_name, c, c.node, handler, client=True)
        self.provided.add(name)
        c.status("info", f"advertised action '{name}'", op.id)

    def unadvertise_action(self, op: UnadvertiseAction) -> None:
        c = self.client
        name = canonical(op.action)
        if name not in self.provided or not c.bus.unadvertise_action(name, c):
            raise ProtocolError(
                f"unadvertise_action: action '{name}' is not advertised by you", op.id
            )
        self.provided.discard(name)
        self._fail_serving(name, f"action '{name}' was unadvertised")
        c.status("info", f"unadvertised action '{name}'", op.id)

    def _entry(self, op: ActionFeedback | ActionResult) -> tuple[asyncio.Future, GoalHandle]:
        entry = self.serving.get(op.id)  # a string or an integer: the spec's check
        if entry is None:
            raise ProtocolError(f"{op.OP}: no goal with id {op.id!r} was sent to you", op.id)
        return entry

    def action_feedback(self, op: ActionFeedback) -> None:
        _fut, handle = self._entry(op)
        try:
            values, _ = from_json(handle.action.atype.feedback, op.values, self.client.bus.types)
        except ConversionError as exc:
            raise ProtocolError(f"action_feedback: field 'values': {exc}", op.id) from None
        handle.feedback(values)

    def action_result(self, op: ActionResult) -> None:
        fut, handle = self._entry(op)
        if fut.done():
            return
        values = op.values
        if op.result:
            try:
                values, _ = from_json(
                    handle.action.atype.result, values or {}, self.client.bus.types
                )
            except ConversionError as exc:
                fut.set_result(GoalOutcome(STATUS_ABORTED, f"invalid result: {exc}", False))
                raise ProtocolError(f"action_result: field 'values': {exc}", op.id) from None
        elif not isinstance(values, str) or not values:
            values = f"goal failed (status {op.status})"
        fut.set_result(GoalOutcome(op.status, values, op.result))

    def _fail_serving(self, name: str | None, text: str) -> None:
        for _gid, (fut, handle) in list(self.serving.items()):
            if (name is None or handle.action.name == name) and not fut.done():
                fut.set_result(GoalOutcome(STATUS_ABORTED, text, False))

    def close(self) -> None:
        """The goals this client sent keep running (as rosbridge's), but those it sent with
        ``cancel_on_disconnect``; what it provides goes."""
        for handle in list(self.cancel_on_close):
            handle.cancel()
        self.cancel_on_close.clear()
        self.goals.clear()
        self._fail_serving(None, f"the action provider ({self.client.node}) disconnected")
        for name in list(self.provided):
            self.client.bus.unadvertise_action(name, self.client)
        self.provided.clear()

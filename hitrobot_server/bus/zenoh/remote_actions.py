"""Another process's action as a local proxy: a goal is its ``send_goal`` query, then a
``get_result`` query that waits for the end; feedback comes on the action's feedback topic and
a cancel is a ``cancel_goal`` query."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import uuid
from typing import Any

import numpy as np
import orjson
import zenoh

from ...types.registry import UnknownType
from ..errors import ServiceError
from ..services import STATUS_ABORTED, STATUS_CANCELED, Action, GoalHandle, GoalOutcome
from .actions import PARTS
from .graph import RemoteEntities
from .peer import ACTION_SUFFIX, REMOTE_OWNER, Peer

log = logging.getLogger(__name__)

Waiting = dict[bytes, GoalHandle]  # goal id -> the goal its feedback goes to


class RemoteActions:
    """Proxies of the other processes' actions, and one feedback subscriber per action."""

    def __init__(self, peer: Peer, remote: RemoteEntities):
        self.peer = peer
        self.remote = remote
        self._feedback: dict[str, tuple[Any, Waiting]] = {}  # action -> (subscriber, goals)

    def remote_action(self, name: str) -> Action | None:
        entity = self.remote.provider(f"{name}{ACTION_SUFFIX}")
        if entity is None:
            return None
        try:
            atype = self.peer.bus.types.action(entity.type_name.removesuffix("_SendGoal"))
        except UnknownType:
            return None
        codec = self.peer.codec
        parts = codec.action_parts(atype)
        keys = {
            p: self.peer.key(f"{name}/_action/{p}", parts[p], codec.service_hash(parts[p]))
            for p in PARTS
        }
        waiting = self._feedback_table(name, parts["feedback"], atype)
        proxy = RemoteAction(self.peer, name, atype, parts, keys, waiting)
        return Action(name, atype, REMOTE_OWNER, entity.node, proxy.run)

    def _feedback_table(self, name: str, fb_type: str, atype: Any) -> Waiting:
        found = self._feedback.get(name)
        if found is not None:
            return found[1]
        waiting: Waiting = {}
        codec = self.peer.codec
        key = self.peer.key(f"{name}/_action/feedback", fb_type, codec.type_hash(fb_type))

        def deliver(payload: bytes) -> None:
            try:
                fb = codec.decode_raw(payload, fb_type)
            except Exception as exc:
                log.warning("zenoh: bad feedback on %s: %s", name, exc)
                return
            handle = waiting.get(bytes(fb.goal_id.uuid))
            if handle is not None:
                handle.feedback(codec.unwrap(fb.feedback, atype.feedback))

        sub = self.peer.session.declare_subscriber(
            key,
            lambda s: self.peer.hop(deliver, s.payload.to_bytes()),
            allowed_origin=zenoh.Locality.REMOTE,
        )
        self._feedback[name] = (sub, waiting)
        return waiting


class RemoteAction:
    """One remote action's goals: :meth:`run` is the proxy's action handler."""

    def __init__(
        self, peer: Peer, name: str, atype: Any, parts: dict[str, str], keys: dict[str, str],
        waiting: Waiting,
    ):
        self.peer = peer
        self.codec = peer.codec
        self.atype = atype
        self.parts = parts
        self.keys = keys  # part -> data key
        self.waiting = waiting
        self.what = f"action '{name}'"

    async def run(self, handle: GoalHandle) -> GoalOutcome:
        goal_id = self.codec.make("unique_identifier_msgs/msg/UUID", uuid=_uuid_array())
        gid = bytes(goal_id.uuid)
        self.waiting[gid] = handle
        accepted: asyncio.Future[bool] = asyncio.get_running_loop().create_future()
        handle.on_cancel.append(lambda: asyncio.ensure_future(self._cancel(goal_id, accepted)))
        try:
            ok = await self._send_goal(goal_id, handle.goal)
            accepted.set_result(ok)
            if not ok:
                return GoalOutcome(STATUS_ABORTED, f"{self.what}: goal rejected", False)
            return await self._result(goal_id)
        except ServiceError as exc:
            status = STATUS_CANCELED if handle.cancelled.is_set() else STATUS_ABORTED
            return GoalOutcome(status, str(exc), False)
        finally:
            self.waiting.pop(gid, None)
            if not accepted.done():
                accepted.set_result(False)

    async def _send_goal(self, goal_id: Any, goal: dict) -> bool:
        """Whether the provider accepted the goal."""
        send_goal = self.parts["send_goal"]
        req = self.codec.make(
            f"{send_goal}_Request", goal_id=goal_id, goal=self.codec.wrap(goal, self.atype.goal)
        )
        raw = self.codec.encode_raw(req, f"{send_goal}_Request")
        data = await self.peer.get(self.keys["send_goal"], raw, 30.0, self.what)
        return bool(self.codec.decode_raw(data, f"{send_goal}_Response").accepted)

    async def _result(self, goal_id: Any) -> GoalOutcome:
        """Wait for the goal's end; a failure's status and text travel as the reply error."""
        get_result = self.parts["get_result"]
        req = self.codec.make(f"{get_result}_Request", goal_id=goal_id)
        raw = self.codec.encode_raw(req, f"{get_result}_Request")
        try:
            data = await self.peer.get(self.keys["get_result"], raw, None, self.what)
        except ServiceError as exc:
            try:
                err = orjson.loads(str(exc))
                return GoalOutcome(int(err["status"]), str(err["text"]), False)
            except (orjson.JSONDecodeError, KeyError, TypeError):
                return GoalOutcome(STATUS_ABORTED, str(exc), False)
        resp = self.codec.decode_raw(data, f"{get_result}_Response")
        values = self.codec.unwrap(resp.result, self.atype.result)
        return GoalOutcome(int(resp.status), values, True)

    async def _cancel(self, goal_id: Any, accepted: asyncio.Future[bool]) -> None:
        if not await accepted:  # a cancel before the goal's reply waits for it
            return
        codec = self.codec
        info = codec.make(
            "action_msgs/msg/GoalInfo",
            goal_id=goal_id,
            stamp=codec.make("builtin_interfaces/msg/Time", sec=0, nanosec=0),
        )
        req = codec.make("action_msgs/srv/CancelGoal_Request", goal_info=info)
        raw = codec.encode_raw(req, "action_msgs/srv/CancelGoal_Request")
        with contextlib.suppress(ServiceError):
            await self.peer.get(self.keys["cancel_goal"], raw, 10.0, self.what)


def _uuid_array() -> np.ndarray:
    return np.frombuffer(uuid.uuid4().bytes, dtype=np.uint8).copy()

"""The in-process bus: topics, services, actions and parameters.

Bridge sessions and in-process nodes are equal participants: each registers under an
*owner* key and a node name (for rosapi). The bus never awaits a subscriber, so one slow
participant cannot delay a publish.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Hashable, Iterable
from typing import Any

from ..types.registry import TypeRegistry, UnknownType
from .errors import ActionError, BusError, ServiceError
from .names import canonical
from .params import ParamStore
from .services import (
    STATUS_ABORTED,
    STATUS_CANCELED,
    Action,
    ActionHandler,
    GoalHandle,
    GoalOutcome,
    Service,
    ServiceHandler,
)
from .topics import Message, Origin, Reply, Subscriber, Topic

log = logging.getLogger(__name__)


class Bus:
    def __init__(
        self,
        types: TypeRegistry,
        *,
        unregister_timeout: float = 10.0,
        clock: Callable[[], float] = time.time,
    ):
        self.types = types
        self.clock = clock
        self.unregister_timeout = unregister_timeout
        self.topics: dict[str, Topic] = {}
        self.services: dict[str, Service] = {}
        self.actions: dict[str, Action] = {}
        self.params = ParamStore()
        self.nodes: dict[str, int] = {}  # node name -> registration count (for rosapi)

    # ---------------------------------------------------------------- topics
    def topic(self, name: str) -> Topic | None:
        return self.topics.get(canonical(name))

    def _topic_for(self, name: str, type_name: str | None, latch: bool = False) -> Topic:
        name = canonical(name)
        topic = self.topics.get(name)
        if type_name is None:
            if topic is None:
                raise BusError(f"topic '{name}' does not exist and no type was given")
            return topic
        try:
            mtype = self.types.msg(type_name)
        except UnknownType as exc:
            raise BusError(str(exc.args[0] if exc.args else exc)) from None
        if topic is None:
            topic = self.topics[name] = Topic(name, mtype, self.types, latch)
        elif topic.mtype is not mtype and topic.mtype.name != mtype.name:
            raise BusError(
                f"topic '{name}' already has type '{self.types.short(topic.type_name)}', "
                f"not '{self.types.short(mtype.name)}'"
            )
        self._cancel_expiry(topic)
        return topic

    def advertise(
        self, name: str, type_name: str | None, owner: Hashable, node: str, latch: bool = False
    ) -> Topic:
        """Register ``owner`` as a publisher; the first latching publisher latches the topic."""
        topic = self._topic_for(name, type_name, latch)
        if latch:
            topic.latched = True
        topic.publishers[owner] = node
        return topic

    def unadvertise(self, name: str, owner: Hashable) -> None:
        topic = self.topic(name)
        if topic is not None and topic.publishers.pop(owner, None) is not None:
            self._maybe_expire(topic)

    def publish(
        self,
        name: str,
        msg: dict,
        stamp: float | None = None,
        reply: Reply | None = None,
        origin: Origin | None = None,
        encoded: dict[Hashable, Any] | None = None,
    ) -> Message:
        """Fan ``msg`` (canonical dict) out to every subscriber of an existing topic.

        ``reply`` reaches the publisher when a subscriber refuses the message; ``encoded``
        seeds the message's encode cache (a client's own text of it, see session/publish.py).
        """
        topic = self.topics.get(name) or self.topics.get(canonical(name))
        if topic is None:
            raise BusError(f"topic '{canonical(name)}' does not exist")
        message = Message(topic, msg, self.clock() if stamp is None else stamp, reply, origin)
        if encoded:
            message.cache.update(encoded)
        topic.fan_out(message)
        return message

    def subscribe(
        self,
        name: str,
        type_name: str | None,
        key: Hashable,
        node: str,
        callback: Subscriber,
        replay_latched: bool = True,
    ) -> Topic:
        """Add a subscriber; a latched topic hands it the last message right away."""
        topic = self._topic_for(name, type_name)
        topic.subscribers[key] = (node, callback)
        if replay_latched and topic.latched and topic.last is not None:
            try:
                callback(topic.last)
            except Exception:
                log.exception("latched replay to %r on %s failed", key, topic.name)
        return topic

    def unsubscribe(self, name: str, key: Hashable) -> None:
        topic = self.topic(name)
        if topic is not None and topic.subscribers.pop(key, None) is not None:
            self._maybe_expire(topic)

    def _maybe_expire(self, topic: Topic) -> None:
        """Drop an unused topic after ``unregister_timeout`` (rosbridge #138's grace period)."""
        if not topic.idle or topic._expiry is not None:
            return
        if self.unregister_timeout <= 0:
            self._expire(topic)
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            self._expire(topic)
            return
        topic._expiry = loop.call_later(self.unregister_timeout, self._expire, topic)

    def _expire(self, topic: Topic) -> None:
        topic._expiry = None
        if topic.idle and self.topics.get(topic.name) is topic:
            del self.topics[topic.name]

    @staticmethod
    def _cancel_expiry(topic: Topic) -> None:
        if topic._expiry is not None:
            topic._expiry.cancel()
            topic._expiry = None

    # ---------------------------------------------------------------- services
    def advertise_service(
        self, name: str, type_name: str, owner: Hashable, node: str, handler: ServiceHandler
    ) -> Service:
        """Register a provider; a later advertiser replaces an earlier one (as rosbridge does)."""
        name = canonical(name)
        try:
            stype = self.types.srv(type_name)
        except UnknownType as exc:
            raise BusError(str(exc.args[0] if exc.args else exc)) from None
        service = self.services[name] = Service(name, stype, owner, node, handler)
        return service

    def unadvertise_service(self, name: str, owner: Hashable) -> bool:
        name = canonical(name)
        service = self.services.get(name)
        if service is None or service.owner != owner:
            return False
        del self.services[name]
        return True

    def service(self, name: str) -> Service | None:
        return self.services.get(canonical(name))

    async def call_service(self, name: str, request: dict, timeout: float | None = None) -> dict:
        """Call a service; raises ServiceError with a user-facing reason on any failure."""
        service = self.service(name)
        if service is None:
            raise ServiceError(f"service '{canonical(name)}' does not exist")
        try:
            if timeout is not None and timeout > 0:
                return await asyncio.wait_for(service.handler(request), timeout)
            return await service.handler(request)
        except TimeoutError:
            raise ServiceError(
                f"service '{service.name}' did not answer within {timeout:g} s"
            ) from None
        except BusError:
            raise
        except Exception as exc:  # a provider bug must not take the caller down
            log.exception("service %s failed", service.name)
            raise ServiceError(f"service '{service.name}' failed: {exc}") from None

    # ---------------------------------------------------------------- actions
    def advertise_action(
        self, name: str, type_name: str, owner: Hashable, node: str, handler: ActionHandler
    ) -> Action:
        name = canonical(name)
        try:
            atype = self.types.action(type_name)
        except UnknownType as exc:
            raise BusError(str(exc.args[0] if exc.args else exc)) from None
        old = self.actions.get(name)
        if old is not None:
            for goal in list(old.goals.values()):
                goal.cancel()
        action = self.actions[name] = Action(name, atype, owner, node, handler)
        return action

    def unadvertise_action(self, name: str, owner: Hashable) -> bool:
        name = canonical(name)
        action = self.actions.get(name)
        if action is None or action.owner != owner:
            return False
        del self.actions[name]
        for goal in list(action.goals.values()):
            goal.cancel()
        return True

    def action(self, name: str) -> Action | None:
        return self.actions.get(canonical(name))

    def start_goal(
        self, name: str, goal: dict, on_feedback: Callable[[dict], None] | None = None
    ) -> tuple[GoalHandle, asyncio.Task[GoalOutcome]]:
        """Hand a goal to the provider; the task resolves to its outcome, never raises."""
        action = self.action(name)
        if action is None:
            raise ActionError(f"action '{canonical(name)}' does not exist")
        handle = GoalHandle(action, action.new_goal_id(), goal, on_feedback)
        action.goals[handle.goal_id] = handle

        async def run() -> GoalOutcome:
            try:
                return await action.handler(handle)
            except asyncio.CancelledError:
                return GoalOutcome(STATUS_CANCELED, "goal cancelled", False)
            except Exception as exc:
                log.exception("action %s failed", action.name)
                return GoalOutcome(STATUS_ABORTED, f"action '{action.name}' failed: {exc}", False)
            finally:
                action.goals.pop(handle.goal_id, None)

        return handle, asyncio.ensure_future(run())

    # ---------------------------------------------------------------- participants
    def register_node(self, node: str) -> None:
        self.nodes[node] = self.nodes.get(node, 0) + 1

    def unregister_node(self, node: str) -> None:
        left = self.nodes.get(node, 0) - 1
        if left > 0:
            self.nodes[node] = left
        else:
            self.nodes.pop(node, None)

    def remove_owner(self, owner: Hashable, keys: Iterable[Hashable] = ()) -> None:
        """Forget everything a participant registered (its subscriptions under ``keys``)."""
        for topic in list(self.topics.values()):
            if topic.publishers.pop(owner, None) is not None:
                self._maybe_expire(topic)
        for key in keys:
            for topic in list(self.topics.values()):
                if topic.subscribers.pop(key, None) is not None:
                    self._maybe_expire(topic)
        for name, service in list(self.services.items()):
            if service.owner == owner:
                del self.services[name]
        for name, action in list(self.actions.items()):
            if action.owner == owner:
                self.unadvertise_action(name, owner)

"""The in-process bus: topics, services, actions and parameters.

Bridge sessions and in-process nodes are equal participants: each registers under an
*owner* key and a node name (for rosapi). The bus never awaits a subscriber, so one slow
participant cannot delay a publish.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
from collections.abc import Callable, Hashable, Iterable
from typing import TypeVar

from ..types.registry import TypeRegistry, UnknownType
from .actions import ActionRegistry
from .clock import wall_clock
from .demand import Demand
from .errors import ActionError, BusError, ServiceError
from .link import BusLink, RemoteGraph
from .names import canonical
from .params import ParamStore
from .requests import Status
from .services import (
    Action,
    ActionHandler,
    GoalHandle,
    GoalOutcome,
    Service,
    ServiceHandler,
    ServiceRegistry,
    calling_as,
)
from .tap import BusTap, client_op
from .topics import Memo, Message, Origin, Subscriber, Topic

log = logging.getLogger(__name__)
T = TypeVar("T")


class Bus:
    def __init__(
        self,
        types: TypeRegistry,
        *,
        unregister_timeout: float = 10.0,
        clock: Callable[[], float] = wall_clock,
    ):
        self.types = types
        self.clock = clock
        self.unregister_timeout = unregister_timeout
        self.topics: dict[str, Topic] = {}
        self._services = ServiceRegistry()
        self.services = self._services.current  # name -> provider
        self._actions = ActionRegistry(self)
        self.actions = self._actions.current  # name -> provider
        self.params = ParamStore()
        self.nodes: dict[str, int] = {}  # node name -> registration count (for rosapi)
        self.log_names: dict[str, str] = {}  # logger (module) name -> node name (for /rosout)
        self.link: BusLink | None = None  # other processes (``--bus zenoh``), if joined
        # Called with (kind, name) whenever a topic, service, action or node comes, goes or
        # changes publishers/subscribers (the Foxglove sessions keep their channels current).
        self.watchers: list[Callable[[str, str], None]] = []
        self.remote_watchers: list[Callable[[str, str], None]] = []  # the same, told by the link
        self.taps: list[BusTap] = []  # observers of every publish (the recorder)
        self._seqs = itertools.count(1)  # numbers every message published here
        self.demand = Demand(self)  # who reads each topic, for the pollers behind them

    # ---------------------------------------------------------------- link hooks
    def _changed(self, kind: str, name: str) -> None:
        if self.link is not None:
            self.link.changed(kind, name)
        _tell([self.demand.changed, *self.watchers], kind, name)

    def remote_changed(self, kind: str, name: str) -> None:
        """The link saw another process's ``kind`` ``name`` come or go."""
        _tell([self.demand.remote_changed, *self.remote_watchers], kind, name)

    def remote_graph(self) -> RemoteGraph:
        """What other processes joined to this bus have (empty without a link)."""
        return self.link.graph() if self.link is not None else RemoteGraph()

    # ---------------------------------------------------------------- topics
    def topic(self, name: str) -> Topic | None:
        return self.topics.get(canonical(name))

    def _topic_for(self, name: str, type_name: str | None, latch: bool = False) -> Topic:
        name = canonical(name)
        topic = self.topics.get(name)
        if type_name is None and topic is None and self.link is not None:
            type_name = self.link.remote_type(name)
        if type_name is None:
            if topic is None:
                raise BusError(f"topic '{name}' does not exist and no type was given")
            return topic
        mtype = _known_type(self.types.msg, type_name)
        if topic is None:
            topic = self.topics[name] = Topic(name, mtype, self.types, latch, self._seqs)
        elif topic.mtype is not mtype and topic.mtype.name != mtype.name:
            raise BusError(
                f"topic '{name}' already has type '{self.types.short(topic.type_name)}', "
                f"not '{self.types.short(mtype.name)}'"
            )
        topic.keep()
        return topic

    def advertise(
        self, name: str, type_name: str | None, owner: Hashable, node: str, latch: bool = False
    ) -> Topic:
        """Register ``owner`` as a publisher; the first latching publisher latches the topic."""
        topic = self._topic_for(name, type_name, latch)
        if latch:
            topic.latched = True
        topic.publishers[owner] = node
        self._changed("topic", topic.name)
        return topic

    def unadvertise(self, name: str, owner: Hashable) -> None:
        topic = self.topic(name)
        if topic is not None and topic.publishers.pop(owner, None) is not None:
            self._maybe_expire(topic)
            self._changed("topic", topic.name)

    def publish(
        self,
        name: str,
        msg: dict,
        stamp: float | None = None,
        reply: Status | None = None,
        origin: Origin | None = None,
        seed: Memo | None = None,
    ) -> Message:
        """Fan ``msg`` (canonical dict) out to every subscriber of an existing topic.

        ``reply`` reaches the publisher when a subscriber or the topic's guard refuses it;
        ``seed`` is what the publisher already has of its encodings (a client's own text of it,
        its size: the wire floor's ``Memo``, kept in the message's ``wire`` slot unread).
        """
        topic = self.topics.get(name) or self.topics.get(canonical(name))
        if topic is None:
            raise BusError(f"topic '{canonical(name)}' does not exist")
        message = Message(topic, msg, self.clock() if stamp is None else stamp, reply, origin, seed)
        if not topic.fan_out(message):  # its guard refused it: no peer or tap sees it either
            return message
        if self.link is not None:
            self.link.published(message)
        for tap in self.taps:
            tap.message(message)
        return message

    def client_called(self, op: str, name: str, origin: Origin) -> None:
        """Tell the taps about a client's ``call_service`` / ``send_action_goal`` that reaches
        a server node: a service no bridge client provides, or any action goal (each tap
        decides what it keeps of them)."""
        if not self.taps:
            return
        target = self.service(name) if op == "call_service" else self.action(name)
        entry = client_op(op, canonical(name), target, origin, self.clock())
        if entry is not None:
            for tap in self.taps:
                tap.client_op(entry)

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
        self._changed("topic", topic.name)
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
            self._changed("topic", topic.name)

    def _maybe_expire(self, topic: Topic) -> None:
        """Drop an unused topic after ``unregister_timeout`` (rosbridge #138's grace period)."""
        topic.expire_later(self.unregister_timeout, self._expire)

    def _expire(self, topic: Topic) -> None:
        if topic.idle and self.topics.get(topic.name) is topic:
            del self.topics[topic.name]
            self._changed("topic", topic.name)

    # ---------------------------------------------------------------- services
    def advertise_service(
        self,
        name: str,
        type_name: str,
        owner: Hashable,
        node: str,
        handler: ServiceHandler,
        *,
        client: bool = False,
    ) -> Service:
        """Register a provider. A bridge client (``client``) may replace another client's
        provider, as rosbridge lets it, but never a node's: the server's own services are not
        for a client to take over. The replaced provider is kept and comes back when the one
        that replaced it goes (:meth:`unadvertise_service`)."""
        name = canonical(name)
        _refuse_takeover("service", name, self.services.get(name), client)
        stype = _known_type(self.types.srv, type_name)
        service = Service(name, stype, owner, node, handler, client)
        self._services.add(service)
        self._changed("service", name)
        return service

    def unadvertise_service(self, name: str, owner: Hashable) -> bool:
        """Withdraw ``owner``'s provider: the current one (the provider it replaced comes
        back) or one waiting under a later replacement."""
        name = canonical(name)
        if not self._services.remove(name, owner):
            return False
        self._changed("service", name)
        return True

    def service(self, name: str) -> Service | None:
        """The local provider, else a proxy for one in another process."""
        found = self.services.get(canonical(name))
        if found is None and self.link is not None:
            return self.link.remote_service(canonical(name))
        return found

    async def call_service(self, name: str, request: dict, timeout: float | None = None,
                           origin: Origin | None = None) -> dict:
        """Call a service; raises ServiceError with a user-facing reason on any failure. A
        bridge client's session passes its ``origin``: the handler reads it with
        :func:`~.services.service_caller`."""
        service = self.service(name)
        if service is None:
            raise ServiceError(f"service '{canonical(name)}' does not exist")
        try:
            with calling_as(origin):
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
        self,
        name: str,
        type_name: str,
        owner: Hashable,
        node: str,
        handler: ActionHandler,
        *,
        client: bool = False,
    ) -> Action:
        """Register a provider; a client may replace a client's action, never a node's."""
        name = canonical(name)
        _refuse_takeover("action", name, self.actions.get(name), client)
        atype = _known_type(self.types.action, type_name)
        action = Action(name, atype, owner, node, handler, client=client)
        self._actions.add(action)
        self._changed("action", name)
        return action

    def unadvertise_action(self, name: str, owner: Hashable) -> bool:
        name = canonical(name)
        if not self._actions.remove(name, owner):
            return False
        self._changed("action", name)
        return True

    def action(self, name: str) -> Action | None:
        """The local provider, else a proxy for one in another process."""
        found = self.actions.get(canonical(name))
        if found is None and self.link is not None:
            return self.link.remote_action(canonical(name))
        return found

    def start_goal(
        self,
        name: str,
        goal: dict,
        on_feedback: Callable[[dict], None] | None = None,
        goal_uuid: bytes | None = None,
    ) -> tuple[GoalHandle, asyncio.Task[GoalOutcome]]:
        """Hand a goal to the provider; the task resolves to its outcome, never raises."""
        action = self.action(name)
        if action is None:
            raise ActionError(f"action '{canonical(name)}' does not exist")
        return self._actions.start(action, goal, on_feedback, goal_uuid, self.clock())

    # ---------------------------------------------------------------- participants
    def node_name(self, name: str) -> str:
        """The name a node registers under (a robot's namespaced view moves it)."""
        return name

    def register_node(self, node: str) -> None:
        self.nodes[node] = self.nodes.get(node, 0) + 1
        self._changed("node", node)

    def unregister_node(self, node: str) -> None:
        left = self.nodes.get(node, 0) - 1
        if left > 0:
            self.nodes[node] = left
        else:
            self.nodes.pop(node, None)
        self._changed("node", node)

    def remove_owner(self, owner: Hashable, keys: Iterable[Hashable] = ()) -> None:
        """Forget everything a participant registered (its subscriptions under ``keys``)."""
        for topic in list(self.topics.values()):
            if topic.publishers.pop(owner, None) is not None:
                self._maybe_expire(topic)
                self._changed("topic", topic.name)
        for key in keys:
            for topic in list(self.topics.values()):
                if topic.subscribers.pop(key, None) is not None:
                    self._maybe_expire(topic)
                    self._changed("topic", topic.name)
        for name in self._services.names():
            while self.unadvertise_service(name, owner):
                pass
        for name, action in list(self.actions.items()):
            if action.owner == owner:
                self.unadvertise_action(name, owner)


def _refuse_takeover(kind: str, name: str, current: Service | Action | None,
                     client: bool) -> None:
    """A client may replace a client's provider (as rosbridge lets it), never a node's: the
    server's own services and actions are not for a client to take over."""
    if client and current is not None and not current.client:
        raise BusError(f"{kind} '{name}' is provided by the server ({current.node}) and "
                       "cannot be advertised by a client")


def _known_type(lookup: Callable[[str], T], type_name: str) -> T:
    """``lookup(type_name)`` from the type registry; an unknown type is a :class:`BusError`
    with the registry's reason."""
    try:
        return lookup(type_name)
    except UnknownType as exc:
        raise BusError(str(exc.args[0] if exc.args else exc)) from None


def _tell(watchers: list[Callable[[str, str], None]], kind: str, name: str) -> None:
    for watcher in list(watchers):
        try:
            watcher(kind, name)
        except Exception:
            log.exception("bus watcher %r failed", watcher)

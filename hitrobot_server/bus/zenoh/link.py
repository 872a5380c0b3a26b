"""The Zenoh link: the bus's :class:`~hitrobot_server.bus.link.BusLink` composed of one Zenoh
session (:mod:`.peer`) and its parts — topics, services, actions served and called, and the
other processes' entities (:mod:`.graph`)."""

from __future__ import annotations

from collections.abc import Iterable

from ..core import Bus
from ..link import Group, RemoteGraph
from ..services import Action, Service
from ..topics import Message
from .actions import ActionServer
from .config import session_config
from .graph import RemoteEntities
from .group import ZenohGroup
from .keys import NODE, PUBLISHER, SERVICE, SUBSCRIBER, Entity
from .peer import ACTION_SUFFIX, Peer
from .remote_actions import RemoteActions
from .services import ServiceBridge
from .topics import TopicBridge


class ZenohLink:
    """Implements :class:`~hitrobot_server.bus.link.BusLink` over one Zenoh session."""

    def __init__(
        self,
        bus: Bus,
        *,
        domain: int = 0,
        config_file: str | None = None,
        connect: Iterable[str] = (),
        listen: Iterable[str] = (),
        shared_params: bool = False,
    ):
        self.bus = bus
        config = session_config(config_file, connect, listen)
        self.peer = Peer(bus, domain, config, shared_params)
        self.topics = TopicBridge(self.peer)
        self.remote = RemoteEntities(self.peer, self._remote_changed)
        self.services = ServiceBridge(self.peer, self.remote)
        self.actions = ActionServer(self.peer, self.services)
        self.remote_actions = RemoteActions(self.peer, self.remote)

    @property
    def zid(self) -> str:
        """This process's Zenoh id ("" until started)."""
        return self.peer.zid

    async def start(self) -> None:
        await self.peer.open()
        self.remote.watch()
        self.bus.link = self
        for name in list(self.bus.nodes):
            self.changed("node", name)
        for kind, names in (
            ("topic", self.bus.topics),
            ("service", self.bus.services),
            ("action", self.bus.actions),
        ):
            for name in list(names):
                self.changed(kind, name)

    async def stop(self) -> None:
        if self.bus.link is self:
            self.bus.link = None
        self.actions.stop()
        await self.peer.close()

    def _remote_changed(self, entity: Entity, alive: bool) -> None:
        """Another process's entity came or went: the topics' bookkeeping, then the bus's
        graph watchers hear it as a change of a topic, service, action or node."""
        self.topics.remote_changed(entity, alive)
        if entity.kind == NODE:
            self.bus.remote_changed("node", entity.node)
        elif entity.kind in (PUBLISHER, SUBSCRIBER):
            self.bus.remote_changed("topic", entity.name)
        elif entity.name.endswith(ACTION_SUFFIX):
            self.bus.remote_changed("action", entity.name[: -len(ACTION_SUFFIX)])
        elif entity.kind == SERVICE:
            self.bus.remote_changed("service", entity.name)

    # ------------------------------------------------------------------ BusLink
    def changed(self, kind: str, name: str) -> None:
        if self.peer.session is None or self.peer.local_only(name):
            return
        if kind in ("topic", "service") and "/_action/" in name:
            return  # an action's own services/topics: the link exports the action itself
        if kind == "node":
            self.peer.sync_tokens(NODE, name, {name} if name in self.bus.nodes else set())
        elif kind == "topic":
            self.topics.sync(name)
        elif kind == "service":
            self.services.sync(name)
        elif kind == "action":
            self.actions.sync(name)

    def published(self, message: Message) -> None:
        self.topics.published(message)

    def remote_type(self, topic: str) -> str | None:
        return self.remote.remote_type(topic)

    def remote_service(self, name: str) -> Service | None:
        return self.services.remote_service(name)

    def remote_action(self, name: str) -> Action | None:
        return self.remote_actions.remote_action(name)

    def graph(self) -> RemoteGraph:
        return self.remote.graph()

    def group(self, name: str) -> Group:
        return ZenohGroup(self.peer, name)

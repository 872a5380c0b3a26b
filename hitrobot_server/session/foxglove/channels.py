"""The server's channels and services as one client knows them, kept current with the whole
graph (this bus and the processes its link joins: other ``--workers``, Zenoh peers): what the
globs allow and has a ROS 2 schema is advertised, what went is unadvertised. Each change costs
the names it touched (O(change)), not a walk of every topic."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from ...protocol import foxglove as fg
from ...types.registry import SrvType

if TYPE_CHECKING:
    from .context import FoxgloveContext
    from .subscribe import SubscribeOps


class ChannelOps:
    def __init__(self, client: FoxgloveContext):
        self.client = client
        self.channels: dict[int, str] = {}  # channel id advertised to this client → topic
        self.by_topic: dict[str, int] = {}  # topic → its channel id advertised
        self.services: dict[int, tuple[str, SrvType]] = {}  # service id → (name, type)
        self.by_service: dict[str, int] = {}  # service name → its id advertised

    def topic_names(self) -> set[str]:
        """Every topic this client was told of or that is in the graph (a whole sync)."""
        return set(self.by_topic) | self.client.shared.graph.topic_names()

    def service_names(self) -> set[str]:
        return set(self.by_service) | self.client.shared.graph.service_names()

    def sync_channels(self, subscriptions: SubscribeOps, names: Iterable[str]) -> None:
        """Advertise the new channels among the topics ``names``, unadvertise the gone (and
        end their subscriptions)."""
        c = self.client
        allowed, graph = c.settings.topics_filter.allows, c.shared.graph
        gone: list[int] = []
        gone_topics: set[str] = set()
        new: list[dict] = []
        for name in names:
            type_name = graph.topic_type(name) if allowed(name) else None
            chan = None if type_name is None else c.shared.channel_of(name, type_name)
            old = self.by_topic.get(name)
            cid = None if chan is None else chan["id"]
            if old == cid:
                continue
            if old is not None:
                gone.append(old)
                gone_topics.add(name)
                del self.channels[old], self.by_topic[name]
            if chan is not None:
                new.append(chan)
                self.channels[cid] = name
                self.by_topic[name] = cid
        if gone:
            subscriptions.drop_topics(gone_topics)
            c.out.send(fg.unadvertise(gone))
        if new:
            c.out.send(fg.advertise(new))

    def sync_services(self, names: Iterable[str]) -> None:
        """The same for the services ``names``."""
        c = self.client
        allowed, graph = c.settings.services_filter.allows, c.shared.graph
        gone: list[int] = []
        new: list[dict] = []
        for name in names:
            type_name = graph.service_type(name) if allowed(name) else None
            stype = None if type_name is None else c.bus.types.srv(type_name)
            desc = None if stype is None else c.shared.service(name, stype)
            old = self.by_service.get(name)
            sid = None if desc is None else desc["id"]
            if old == sid:
                continue
            if old is not None:
                gone.append(old)
                del self.services[old], self.by_service[name]
            if desc is not None:
                new.append(desc)
                self.services[sid] = (name, stype)
                self.by_service[name] = sid
        if gone:
            c.out.send(fg.unadvertise_services(gone))
        if new:
            c.out.send(fg.advertise_services(new))

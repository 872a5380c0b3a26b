"""The server's channels and services as one client knows them, kept current with the bus:
what the globs allow and has a ROS 2 schema is advertised, what went is unadvertised. Each
bus change costs the names it touched (O(change)), not a walk of every topic."""

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
        """Every topic this client was told of or that is on the bus (a whole sync)."""
        return set(self.by_topic) | set(self.client.bus.topics)

    def service_names(self) -> set[str]:
        return set(self.by_service) | set(self.client.bus.services)

    def sync_channels(self, subscriptions: SubscribeOps, names: Iterable[str]) -> None:
        """Advertise the new channels among the topics ``names``, unadvertise the gone (and
        end their subscriptions)."""
        c = self.client
        allowed = c.settings.topics_filter.allows
        gone: list[int] = []
        gone_topics: set[str] = set()
        new: list[dict] = []
        for name in names:
            topic = c.bus.topics.get(name)
            chan = c.shared.channel(topic) if topic is not None and allowed(name) else None
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
        allowed = c.settings.services_filter.allows
        gone: list[int] = []
        new: list[dict] = []
        for name in names:
            svc = c.bus.services.get(name)
            desc = c.shared.service(name, svc.stype) if svc is not None and allowed(name) \
                else None
            old = self.by_service.get(name)
            sid = None if desc is None else desc["id"]
            if old == sid:
                continue
            if old is not None:
                gone.append(old)
                del self.services[old], self.by_service[name]
            if desc is not None:
                new.append(desc)
                self.services[sid] = (name, svc.stype)
                self.by_service[name] = sid
        if gone:
            c.out.send(fg.unadvertise_services(gone))
        if new:
            c.out.send(fg.advertise_services(new))

"""The connection graph (``subscribeConnectionGraph``): who publishes and subscribes each
topic and who provides each service, from the bus's one graph query (local and joined
processes) when the client subscribes, then updated by the names each bus change touched
(O(change)): an update lists only what changed."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ...bus.graph import whole_graph
from ...protocol import foxglove as fg

if TYPE_CHECKING:
    from .context import FoxgloveContext


@dataclass
class Sent:
    """The graph as this client was last told it."""

    published: dict[str, list[str]] = field(default_factory=dict)
    subscribed: dict[str, list[str]] = field(default_factory=dict)
    services: dict[str, list[str]] = field(default_factory=dict)


class GraphOps:
    def __init__(self, client: FoxgloveContext):
        self.client = client
        self.graph: Sent | None = None  # last graph sent, if subscribed

    def subscribe(self, op: fg.SubscribeConnectionGraph) -> None:
        self.graph = Sent()
        self.send()

    def unsubscribe(self, op: fg.UnsubscribeConnectionGraph) -> None:
        self.graph = None

    def send(self) -> None:
        """The whole graph the globs allow (what differs from the last one sent)."""
        settings = self.client.settings
        topics_ok, services_ok = settings.topics_filter.allows, settings.services_filter.allows
        graph = whole_graph(self.client.bus)
        now = Sent(
            {name: sorted(nodes) for name, nodes in graph.publishers.items()
             if nodes and topics_ok(name)},
            {name: sorted(nodes) for name, nodes in graph.subscribers.items()
             if nodes and topics_ok(name)},
            {name: [node] for name, (_type, node) in graph.services.items() if services_ok(name)})
        last = self.graph or Sent()
        names = set(last.published) | set(last.subscribed) | set(now.published) | \
            set(now.subscribed)
        self._update(now, names, set(last.services) | set(now.services))

    def changed(self, topics: Iterable[str], services: Iterable[str]) -> None:
        """The bus changed these topics and services: what changed of them, if subscribed."""
        if self.graph is None:
            return
        c = self.client
        topics_ok, services_ok = c.settings.topics_filter.allows, c.settings.services_filter.allows
        remote = c.bus.remote_graph()
        now = Sent()
        topics = [name for name in topics if topics_ok(name)]
        for name in topics:
            topic = c.bus.topics.get(name)
            pubs = set(remote.publishers.get(name, ()))
            subs = set(remote.subscribers.get(name, ()))
            if topic is not None:
                pubs.update(topic.publishers.values())
                subs.update(node for node, _callback in topic.subscribers.values())
            if pubs:
                now.published[name] = sorted(pubs)
            if subs:
                now.subscribed[name] = sorted(subs)
        services = [name for name in services if services_ok(name)]
        for name in services:
            svc = c.bus.services.get(name)
            node = svc.node if svc is not None else remote.services.get(name, (None, None))[1]
            if node is not None:
                now.services[name] = [node]
        self._update(now, topics, services)

    def _update(self, now: Sent, topics: Iterable[str], services: Iterable[str]) -> None:
        """Tell the client what ``now`` changes of ``topics`` and ``services``."""
        last = self.graph or Sent()
        published: dict[str, list[str]] = {}
        subscribed: dict[str, list[str]] = {}
        offered: dict[str, list[str]] = {}
        removed_topics, removed_services = [], []
        for name in topics:
            pubs, subs = now.published.get(name), now.subscribed.get(name)
            if pubs is None and subs is None:
                if name in last.published or name in last.subscribed:
                    removed_topics.append(name)
                    last.published.pop(name, None)
                    last.subscribed.pop(name, None)
                continue
            for mine, theirs, out in ((pubs, last.published, published),
                                      (subs, last.subscribed, subscribed)):
                if mine != theirs.get(name):
                    out[name] = mine or []
                    if mine:
                        theirs[name] = mine
                    else:
                        theirs.pop(name, None)
        for name in services:
            nodes = now.services.get(name)
            if nodes is None:
                if last.services.pop(name, None) is not None:
                    removed_services.append(name)
            elif nodes != last.services.get(name):
                offered[name] = last.services[name] = nodes
        self.graph = last
        if published or subscribed or offered or removed_topics or removed_services:
            self.client.out.send(fg.connection_graph_update(
                published, subscribed, offered, sorted(removed_topics), sorted(removed_services)))

"""The connection graph (``subscribeConnectionGraph``): who publishes and subscribes each
topic and who provides each service, from the bus's one graph query (local and joined
processes), sent again whenever it changes."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ...bus.graph import whole_graph
from ...protocol import foxglove as fg

if TYPE_CHECKING:
    from .context import FoxgloveContext

Snapshot = tuple[dict[str, list[str]], dict[str, list[str]], dict[str, list[str]]]


class GraphOps:
    def __init__(self, client: FoxgloveContext):
        self.client = client
        self.graph: Snapshot | None = None  # last graph sent, if subscribed

    def subscribe(self, op: dict) -> None:
        self.graph = ({}, {}, {})
        self.send()

    def unsubscribe(self, op: dict) -> None:
        self.graph = None

    def changed(self) -> None:
        if self.graph is not None:
            self.send()

    def send(self) -> None:
        """The update from the last graph sent, when the graph the globs allow changed."""
        settings = self.client.settings
        topics_ok, services_ok = settings.topics_filter.allows, settings.services_filter.allows
        graph = whole_graph(self.client.bus)
        published = {name: sorted(nodes) for name, nodes in graph.publishers.items()
                     if nodes and topics_ok(name)}
        subscribed = {name: sorted(nodes) for name, nodes in graph.subscribers.items()
                      if nodes and topics_ok(name)}
        services = {name: [node] for name, (_type, node) in graph.services.items()
                    if services_ok(name)}
        last = self.graph or ({}, {}, {})
        if (published, subscribed, services) == last:
            return
        removed_topics = sorted((set(last[0]) | set(last[1])) - set(published) - set(subscribed))
        removed_services = sorted(set(last[2]) - set(services))
        self.graph = (published, subscribed, services)
        self.client.out.send(fg.connection_graph_update(
            published, subscribed, services, removed_topics, removed_services
        ))

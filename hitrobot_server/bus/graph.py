"""The whole ROS graph: this process's bus and the processes joined to it by a link (other
``--workers``, Zenoh peers). rosapi, Foxglove's connection graph and diagnostics read it in one
query (``whole_graph``); a participant that follows it (Foxglove's channels) holds a
:class:`GraphView`, which names what is there on either side and hears both sides' changes."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from ..types.registry import UnknownType
from .core import Bus


@dataclass
class Graph:
    """Names are absolute; a name here and elsewhere shows this process's type and node."""

    nodes: set[str] = field(default_factory=set)
    topics: dict[str, str] = field(default_factory=dict)  # name -> type (pkg/msg/Type)
    publishers: dict[str, set[str]] = field(default_factory=dict)  # topic -> node names
    subscribers: dict[str, set[str]] = field(default_factory=dict)  # topic -> node names
    services: dict[str, tuple[str, str]] = field(default_factory=dict)  # name -> (type, node)
    actions: dict[str, tuple[str, str]] = field(default_factory=dict)  # name -> (type, node)


def whole_graph(bus: Bus) -> Graph:
    """Everything on ``bus`` and on the processes its link joins (a snapshot)."""
    remote = bus.remote_graph()
    graph = Graph(
        nodes=set(bus.nodes) | remote.nodes,
        topics=dict(remote.topics),
        publishers={name: set(nodes) for name, nodes in remote.publishers.items()},
        subscribers={name: set(nodes) for name, nodes in remote.subscribers.items()},
        services=dict(remote.services),
        actions=dict(remote.actions),
    )
    for topic in list(bus.topics.values()):
        graph.topics[topic.name] = topic.type_name
        if topic.publishers:
            graph.publishers.setdefault(topic.name, set()).update(topic.publishers.values())
        if topic.subscribers:
            graph.subscribers.setdefault(topic.name, set()).update(
                node for node, _callback in topic.subscribers.values()
            )
    graph.services.update((s.name, (s.type_name, s.node)) for s in list(bus.services.values()))
    graph.actions.update((a.name, (a.type_name, a.node)) for a in list(bus.actions.values()))
    return graph


Watcher = Callable[[str, str], None]


class GraphView:
    """The whole graph as one participant follows it: what topics and services there are
    (here or across the link) with their types, and one change event ``(kind, name)`` for a
    change on either side (a local topic, service, action or node, or another process's)."""

    def __init__(self, bus: Bus):
        self.bus = bus

    def watch(self, watcher: Watcher) -> None:
        """Hear every change, local (``Bus.watchers``) or remote (``Bus.remote_watchers``,
        which the link calls), from now on."""
        self.bus.watchers.append(watcher)
        self.bus.remote_watchers.append(watcher)

    def unwatch(self, watcher: Watcher) -> None:
        for hooks in (self.bus.watchers, self.bus.remote_watchers):
            if watcher in hooks:
                hooks.remove(watcher)

    def topic_names(self) -> set[str]:
        return set(self.bus.topics) | set(self.bus.remote_graph().topics)

    def topic_type(self, name: str) -> str | None:
        """The topic's type (this process's when it has it), or None where it is nowhere."""
        topic = self.bus.topics.get(name)
        if topic is not None:
            return topic.type_name
        return self._known(self.bus.types.msg, self.bus.remote_graph().topics.get(name))

    def service_names(self) -> set[str]:
        return set(self.bus.services) | set(self.bus.remote_graph().services)

    def service_type(self, name: str) -> str | None:
        svc = self.bus.services.get(name)
        if svc is not None:
            return svc.stype.name
        remote = self.bus.remote_graph().services.get(name)
        return None if remote is None else self._known(self.bus.types.srv, remote[0])

    @staticmethod
    def _known(lookup: Callable[[str], object], type_name: str | None) -> str | None:
        """A remote type in this process's spelling; None when unknown here (no schema)."""
        if not type_name:
            return None
        try:
            return lookup(type_name).name  # type: ignore[attr-defined]
        except UnknownType:
            return None

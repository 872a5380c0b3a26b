"""The whole ROS graph in one query: this process's bus and the processes joined to it by a
link (other ``--workers``, Zenoh peers). rosapi, Foxglove's connection graph and diagnostics all
read it here, so they list the same graph."""

from __future__ import annotations

from dataclasses import dataclass, field

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

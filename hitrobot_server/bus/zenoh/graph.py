"""The other processes as their liveliness tokens show them: entities come with a token and go
with it (a process that dies loses its tokens), and rosapi's lists are made of them."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import zenoh

from ..action_interfaces import hidden_names
from ..link import RemoteGraph
from .keys import PUBLISHER, SERVICE, SUBSCRIBER, Entity, parse_token
from .peer import ACTION_SUFFIX, Peer


class RemoteEntities:
    """Every entity another process announces, keyed by its token; ``on_change(entity,
    alive)`` hears each one that comes or goes."""

    def __init__(self, peer: Peer, on_change: Callable[[Entity, bool], None]):
        self.peer = peer
        self._on_change = on_change
        self._remote: dict[str, Entity] = {}  # token key -> entity of another process
        self._graph: RemoteGraph | None = None
        self._watch: Any = None  # the liveliness subscriber, held while the session lasts

    def watch(self) -> None:
        """Follow the tokens of the link's domain (those already there come first)."""
        assert self.peer.session is not None
        self._watch = self.peer.session.liveliness().declare_subscriber(
            f"@ros2_lv/{self.peer.domain}/**", self._on_token, history=True
        )

    def _on_token(self, sample: zenoh.Sample) -> None:
        self.peer.hop(self._token_event, str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)

    def _token_event(self, key: str, alive: bool) -> None:
        entity = parse_token(key)
        if entity is None or entity.zid == self.peer.zid:
            return
        if alive:
            if key in self._remote:
                return
            self._remote[key] = entity
        elif self._remote.pop(key, None) is None:
            return
        self._graph = None
        self._on_change(entity, alive)

    def provider(self, name: str) -> Entity | None:
        """The other process serving ``name``, if any."""
        found = [e for e in self._remote.values() if e.kind == SERVICE and e.name == name]
        return found[0] if found else None

    def remote_type(self, topic: str) -> str | None:
        for e in self._remote.values():
            if e.name == topic and e.kind in (PUBLISHER, SUBSCRIBER) and e.type_name:
                return e.type_name if self.peer.bus.types.has_msg(e.type_name) else None
        return None

    def graph(self) -> RemoteGraph:
        if self._graph is None:
            g = RemoteGraph()
            for e in self._remote.values():
                g.nodes.add(e.node)
                if e.kind in (PUBLISHER, SUBSCRIBER):
                    if "/_action/" in e.name:
                        continue
                    g.topics.setdefault(e.name, e.type_name)
                    side = g.publishers if e.kind == PUBLISHER else g.subscribers
                    side.setdefault(e.name, set()).add(e.node)
                elif e.kind == SERVICE:
                    if e.name.endswith(ACTION_SUFFIX):
                        g.actions[e.name[: -len(ACTION_SUFFIX)]] = (
                            e.type_name.removesuffix("_SendGoal"),
                            e.node,
                        )
                    elif "/_action/" not in e.name:
                        g.services[e.name] = (e.type_name, e.node)
            _add_action_interfaces(g)
            self._graph = g
        return self._graph


def _add_action_interfaces(g: RemoteGraph) -> None:
    """List each remote action's services and topics as the local ones are."""
    for action, (atype, node) in g.actions.items():
        services, topics = hidden_names(action, atype)
        g.services.update((n, (t, node)) for n, t in services.items())
        g.topics.update(topics)
        for topic in topics:
            g.publishers.setdefault(topic, set()).add(node)

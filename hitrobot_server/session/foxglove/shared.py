"""What all Foxglove clients of one server share: one codec, the whole graph's view (local and
across the link), channel and service ids that mean the same to every client (so they share
encoded frames), and the clients' numbering."""

from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass, field

from ...bus.cdr import Ros2Codec, codec_for
from ...bus.core import Bus
from ...bus.graph import GraphView
from ...bus.topics import Topic
from ...protocol import foxglove as fg
from ...types.registry import SrvType
from ..access import Access
from ..offload import WorkerPool

log = logging.getLogger(__name__)

MAX_REMEMBERED = 4096
"""Channels/services remembered server-wide before those no longer on the bus are forgotten."""


@dataclass
class FoxgloveShared:
    """One per server: channel and service descriptions by (name, type), and client ids."""

    codec: Ros2Codec
    graph: GraphView  # the channels' and services' source: this bus and its link
    pool: WorkerPool = field(default_factory=WorkerPool)  # the server's: big decodes
    access: Access = field(default_factory=Access)  # tokens and roles (the server's)
    _channels: dict[tuple[str, str], dict] = field(default_factory=dict)
    _services: dict[tuple[str, str], dict] = field(default_factory=dict)
    _ids: itertools.count = field(default_factory=lambda: itertools.count(1))
    client_ids: itertools.count = field(default_factory=lambda: itertools.count(1))
    _prune_channels: int = 0  # twice the channels live at the last walk (the next is past it)
    _prune_services: int = 0

    @classmethod
    def for_bus(cls, bus: Bus, pool: WorkerPool | None = None) -> FoxgloveShared:
        return cls(codec_for(bus.types), GraphView(bus), pool or WorkerPool())

    def prune(self) -> None:
        """Forget channels and services gone from the graph once there are many (clients can
        make topics and services of any name): a returning topic then gets a new id. A walk
        happens only when the remembered doubled since the last, so its cost is shared out
        over the changes that made them (not paid on every bus change while many are live)."""
        if len(self._channels) > max(MAX_REMEMBERED, self._prune_channels):
            graph = self.graph
            live = {(name, graph.topic_type(name)) for name in graph.topic_names()}
            self._channels = {k: v for k, v in self._channels.items() if k in live}
            self._prune_channels = 2 * len(self._channels)
        if len(self._services) > max(MAX_REMEMBERED, self._prune_services):
            graph = self.graph
            live = {(name, graph.service_type(name)) for name in graph.service_names()}
            self._services = {k: v for k, v in self._services.items() if k in live}
            self._prune_services = 2 * len(self._services)

    def channel(self, topic: Topic) -> dict | None:
        """The channel of a local topic (see :meth:`channel_of`)."""
        return self.channel_of(topic.name, topic.type_name)

    def channel_of(self, name: str, type_name: str) -> dict | None:
        """The channel of a topic (its id and schema), or None when it has no ROS 2 schema."""
        key = (name, type_name)
        found = self._channels.get(key)
        if found is None:
            try:
                schema = self.codec.definition(type_name)
            except Exception as exc:
                log.debug("no ros2msg schema for %s (%s): %s", name, type_name, exc)
                return None
            found = self._channels[key] = fg.channel(next(self._ids), name, type_name, schema)
        return found

    def service(self, name: str, stype: SrvType) -> dict | None:
        key = (name, stype.name)
        found = self._services.get(key)
        if found is None:
            try:
                req = (stype.request.name, self.codec.definition(stype.request.name))
                resp = (stype.response.name, self.codec.definition(stype.response.name))
            except Exception as exc:
                log.debug("no ros2msg schema for service %s: %s", name, exc)
                return None
            found = self._services[key] = fg.service(next(self._ids), name, stype.name, req,
                                                     resp)
        return found

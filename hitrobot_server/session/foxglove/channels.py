"""The server's channels and services as one client knows them, kept current with the bus:
what the globs allow and has a ROS 2 schema is advertised, what went is unadvertised."""

from __future__ import annotations

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
        self.services: dict[int, tuple[str, SrvType]] = {}  # service id → (name, type)

    def sync_channels(self, subscriptions: SubscribeOps) -> None:
        """Advertise the new channels, unadvertise the gone (and end their subscriptions)."""
        c = self.client
        allowed = c.settings.topics_filter.allows
        current: dict[int, dict] = {}
        for topic in list(c.bus.topics.values()):
            if allowed(topic.name):
                chan = c.shared.channel(topic)
                if chan is not None:
                    current[chan["id"]] = chan
        gone = [cid for cid in self.channels if cid not in current]
        new = [chan for cid, chan in current.items() if cid not in self.channels]
        if gone:
            subscriptions.keep_only({chan["topic"] for chan in current.values()})
            for cid in gone:
                del self.channels[cid]
            c.out.send(fg.unadvertise(gone))
        if new:
            for chan in new:
                self.channels[chan["id"]] = chan["topic"]
            c.out.send(fg.advertise(new))

    def sync_services(self) -> None:
        c = self.client
        allowed = c.settings.services_filter.allows
        current: dict[int, tuple[str, SrvType, dict]] = {}
        for name, svc in list(c.bus.services.items()):
            if allowed(name):
                desc = c.shared.service(name, svc.stype)
                if desc is not None:
                    current[desc["id"]] = (name, svc.stype, desc)
        gone = [sid for sid in self.services if sid not in current]
        new = [(sid, entry) for sid, entry in current.items() if sid not in self.services]
        if gone:
            for sid in gone:
                del self.services[sid]
            c.out.send(fg.unadvertise_services(gone))
        if new:
            for sid, (name, stype, _desc) in new:
                self.services[sid] = (name, stype)
            c.out.send(fg.advertise_services([desc for _sid, (_n, _t, desc) in new]))

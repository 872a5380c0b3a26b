"""Client publishing: ``advertise`` / ``unadvertise`` of client channels and their binary
message data, published on the bus."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ...bus.errors import BusError
from ...bus.names import canonical, valid_name
from ...protocol import foxglove as fg
from ...types.registry import MsgType, UnknownType
from .frames import decode_cdr

if TYPE_CHECKING:
    from .context import FoxgloveContext


@dataclass(slots=True)
class ClientChannel:
    topic: str
    mtype: MsgType


class PublishOps:
    def __init__(self, client: FoxgloveContext):
        self.client = client
        self.client_channels: dict[int, ClientChannel] = {}

    def advertise(self, op: dict) -> None:
        c = self.client
        for chan in op["channels"]:
            where = f"advertise: channel {chan.id}"
            if chan.id in self.client_channels:
                c.out.status(fg.ERROR, f"{where}: id already advertised")
                continue
            if chan.encoding != fg.ENCODING:
                c.out.status(fg.ERROR, f"{where}: field 'encoding' {chan.encoding!r:.40} is not "
                             f"supported (only '{fg.ENCODING}')")
                continue
            if not valid_name(chan.topic):
                c.out.status(fg.ERROR, f"{where}: field 'topic' {chan.topic!r:.80} is not a "
                             "valid topic name")
                continue
            name = canonical(chan.topic)
            if not c.settings.topics_filter.allows(name):
                c.out.status(fg.ERROR, f"{where}: topic '{name}' is not allowed by --topics-glob")
                continue
            try:
                mtype = c.bus.types.msg(chan.schema_name)
                c.bus.advertise(name, mtype.name, c, c.node)
            except (UnknownType, BusError) as exc:
                text = exc.args[0] if exc.args else exc
                c.out.status(fg.ERROR, f"{where}: field 'schemaName': {text}")
                continue
            self.client_channels[chan.id] = ClientChannel(name, mtype)

    def unadvertise(self, op: dict) -> None:
        for cid in op["channelIds"]:
            chan = self.client_channels.pop(cid, None)
            if chan is None:
                self.client.out.status(fg.ERROR, f"unadvertise: unknown client channel id {cid}")
                continue
            if all(c.topic != chan.topic for c in self.client_channels.values()):
                self.client.bus.unadvertise(chan.topic, self.client)

    def message(self, frame: fg.ClientMessage) -> None:
        """One binary message on a client channel."""
        c = self.client
        chan = self.client_channels.get(frame.channel_id)
        if chan is None:
            raise fg.FoxgloveError(f"message data: unknown client channel id {frame.channel_id}"
                                   " (advertise it first)")
        try:
            msg = decode_cdr(c.codec, frame.payload, chan.mtype)
        except Exception as exc:
            raise fg.FoxgloveError(
                f"message data: channel {frame.channel_id} ({chan.topic}): the CDR does not "
                f"match {chan.mtype.name}: {exc}"
            ) from None
        try:
            c.bus.publish(chan.topic, msg, reply=self._reply, origin=c.origin)
        except BusError as exc:
            raise fg.FoxgloveError(f"message data: {exc}") from None

    def _reply(self, level: str, text: str) -> None:
        """A node's answer to a message this client published (refusals, successes)."""
        self.client.out.status({"info": fg.INFO, "warning": fg.WARNING}.get(level, fg.ERROR),
                               text)

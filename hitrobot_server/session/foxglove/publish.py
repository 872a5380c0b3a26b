"""Client publishing: ``advertise`` / ``unadvertise`` of client channels and their binary
message data, published on the bus."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ...bus.errors import BusError
from ...bus.names import canonical, valid_name
from ...protocol import foxglove as fg
from ...protocol.bulk import OFFLOAD_BYTES
from ...types.registry import MsgType, TypeRegistry, UnknownType
from ..client import Pending
from .frames import CdrError, decode_cdr, decode_cdr_default

if TYPE_CHECKING:
    from .context import FoxgloveContext

log = logging.getLogger(__name__)


@dataclass(slots=True)
class ClientChannel:
    topic: str
    mtype: MsgType


def flat(mtype: MsgType, types: TypeRegistry, depth: int = 0) -> bool:
    """Whether a message of this type decodes as a copy of its bytes: no array of messages
    or strings at any depth, so its big parts are numeric arrays that stay numpy (a LaserScan,
    a map, an image). Such a one is decoded here, in about the time of a copy: sending it to
    the worker pool would cost two more copies of it (pickled there and back) and the loop's
    time to make them."""
    memo: dict[str, bool] = types.plans["foxglove_flat"]
    found = memo.get(mtype.name)
    if found is None:
        found = depth < 8 and all(
            (f.array is None and (not f.is_msg or flat(types.msg(f.type), types, depth + 1)))
            or (not f.is_msg and f.type != "string")
            for f in mtype.fields)
        memo[mtype.name] = found
    return found


MAX_CLIENT_CHANNELS = 1024
"""Most channels one client may advertise at once: each is a publisher on the bus that every
other Foxglove client is told about."""


class PublishOps:
    def __init__(self, client: FoxgloveContext):
        self.client = client
        self.client_channels: dict[int, ClientChannel] = {}
        self.per_topic: dict[str, int] = {}  # topic → how many of client_channels publish it

    def advertise(self, op: fg.Advertise) -> None:
        refused: dict[str, list[str]] = {}
        for chan in op.channels:
            why = self._advertise_one(chan)
            if why is not None:
                refused.setdefault(why, []).append(str(chan.id))
        for why, ids in refused.items():
            self.client.out.errors(f"advertise: {why}; channel(s)", ids)

    def _advertise_one(self, chan: fg.ClientChannel) -> str | None:
        """Advertise one client channel; why not (the op's refusals are grouped by it)."""
        c = self.client
        if chan.id in self.client_channels:
            return "id already advertised"
        if len(self.client_channels) >= MAX_CLIENT_CHANNELS:
            return (f"this client has {MAX_CLIENT_CHANNELS} channels advertised, the most one "
                    "client may (unadvertise some first); refused")
        if chan.encoding != fg.ENCODING:
            return (f"field 'encoding' {chan.encoding!r:.40} is not supported "
                    f"(only '{fg.ENCODING}')")
        if not valid_name(chan.topic):
            return f"field 'topic' {chan.topic!r:.80} is not a valid topic name"
        name = canonical(chan.topic)
        if not c.settings.topics_filter.allows(name):
            return f"topic '{name}' is not allowed by --topics-glob"
        try:
            mtype = c.bus.types.msg(chan.schema_name)
            c.bus.advertise(name, mtype.name, c, c.node)
        except (UnknownType, BusError) as exc:
            return f"field 'schemaName': {exc.args[0] if exc.args else exc}"
        self.client_channels[chan.id] = ClientChannel(name, mtype)
        self.per_topic[name] = self.per_topic.get(name, 0) + 1
        return None

    def unadvertise(self, op: fg.Unadvertise) -> None:
        unknown = []
        for cid in op.channel_ids:
            chan = self.client_channels.pop(cid, None)
            if chan is None:
                unknown.append(str(cid))
                continue
            left = self.per_topic[chan.topic] - 1
            if left:
                self.per_topic[chan.topic] = left
            else:
                del self.per_topic[chan.topic]
                self.client.bus.unadvertise(chan.topic, self.client)
        self.client.out.errors("unadvertise: unknown client channel id(s)", unknown)

    def message(self, frame: fg.ClientMessage) -> Pending:
        """One binary message on a client channel; a big one is decoded in the worker pool
        (the task the transport awaits before the next frame), a small one here."""
        c = self.client
        chan = self.client_channels.get(frame.channel_id)
        if chan is None:
            raise fg.FoxgloveError(f"message data: unknown client channel id {frame.channel_id}"
                                   " (advertise it first)")
        if (len(frame.payload) >= OFFLOAD_BYTES and c.bus.types is TypeRegistry.default()
                and not flat(chan.mtype, c.bus.types)):
            return c.spawn(self._offloaded(frame, chan))
        try:
            msg = decode_cdr(c.codec, frame.payload, chan.mtype)
        except Exception as exc:
            raise self._mismatch(frame, chan, exc) from None
        self._publish(chan, msg)
        return None

    async def _offloaded(self, frame: fg.ClientMessage, chan: ClientChannel) -> None:
        c = self.client
        try:
            msg = await c.pool.run(decode_cdr_default, chan.mtype.name, frame.payload)
        except CdrError as exc:
            c.out.status(fg.ERROR, str(self._mismatch(frame, chan, exc)))
            return
        except Exception as exc:  # the pool broke (a worker was killed): say so, go on
            log.warning("foxglove client %s: decoding a big message failed: %r", c.node, exc)
            c.out.status(fg.ERROR, f"message data: channel {frame.channel_id}: decoding "
                         f"failed ({exc.__class__.__name__}); not published")
            return
        try:
            self._publish(chan, msg)
        except fg.FoxgloveError as exc:
            c.out.status(fg.ERROR, str(exc))

    @staticmethod
    def _mismatch(frame: fg.ClientMessage, chan: ClientChannel, exc: Exception) -> Exception:
        return fg.FoxgloveError(
            f"message data: channel {frame.channel_id} ({chan.topic}): the CDR does not "
            f"match {chan.mtype.name}: {exc}")

    def _publish(self, chan: ClientChannel, msg: dict) -> None:
        c = self.client
        try:
            c.bus.publish(chan.topic, msg, reply=self._reply, origin=c.origin)
        except BusError as exc:
            raise fg.FoxgloveError(f"message data: {exc}") from None

    def _reply(self, level: str, text: str) -> None:
        """A node's answer to a message this client published (refusals, successes)."""
        self.client.out.status({"info": fg.INFO, "warning": fg.WARNING}.get(level, fg.ERROR),
                               text)

"""``subscribe`` / ``unsubscribe``: a client's subscriptions to the server's channels. A
message's CDR is encoded once (``Message.cdr``) and each subscription gets it behind its own
13-byte header, made once per message (:data:`DATA`, a key of the message's memo)."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

from ...bus.cdr import codec_for
from ...bus.errors import BusError
from ...bus.topics import MemoKey, Message
from ...protocol import foxglove as fg

if TYPE_CHECKING:
    from .context import FoxgloveContext


MAX_SUBSCRIPTIONS = 4096
"""Most subscriptions one client may hold (each message is framed once per subscription)."""
MAX_PER_CHANNEL = 16
"""Most subscriptions of one client to one channel: the protocol allows several, a client
needs one; 100,000 ids on ``/scan`` would frame every scan 100,000 times."""


def _data(message: Message, sub_id: int) -> bytes:
    cdr = message.cdr_bytes  # made already by the delivery
    if cdr is None:
        cdr = message.cdr(codec_for(message.topic.types))
    return fg.message_data(sub_id, fg.nanoseconds(message.stamp), cdr)


DATA: MemoKey[bytes] = MemoKey("foxglove: message data frame", _data)
"""A Foxglove message data frame around the message's CDR; variant: the subscription id."""


class SubscribeOps:
    def __init__(self, client: FoxgloveContext, channels: dict[int, str]):
        self.client = client
        self.channels = channels  # the channels advertised to this client (id → topic)
        self.subs: dict[int, str] = {}  # subscription id → topic
        self.per_topic: dict[str, int] = {}  # topic → how many of subs are on it
        self._bad_encodings: set[str] = set()
        self._next_id = 1  # where an SDK client's next server-given id is looked for

    def subscribe(self, op: fg.Subscribe) -> None:
        c = self.client
        given: list[tuple[int, int]] = []
        refused: dict[str, list[str]] = {}
        for sub_id, channel_id in op.subscriptions:
            topic = self.channels.get(channel_id)
            why = self._refusal(sub_id, topic)
            if why is not None:
                named = channel_id if topic is None or sub_id is None else sub_id
                refused.setdefault(why, []).append(str(named))
                continue
            if sub_id is None:
                sub_id = self._free_id()
            self._add(sub_id, topic)  # before subscribing: a latched topic delivers at once
            try:
                c.bus.subscribe(topic, None, (c, sub_id), c.node,
                                functools.partial(self._deliver, sub_id))
            except BusError as exc:  # the topic went since it was advertised
                self._remove(sub_id)
                c.out.status(fg.ERROR, f"subscribe: channel {channel_id}: {exc}")
                continue
            given.append((sub_id, channel_id))
        for why, items in refused.items():
            c.out.errors(f"subscribe: {why}", items)
        if c.subprotocol == fg.SUBPROTOCOL_SDK and given:
            c.out.send(fg.subscription_response(given))

    def _refusal(self, sub_id: int | None, topic: str | None) -> str | None:
        """Why one subscription is refused (the reason groups the op's refusals), or None."""
        if topic is None:
            return "unknown channel id(s)"
        if sub_id is None and self.client.subprotocol == fg.SUBPROTOCOL_V1:
            return "field 'subscriptions[].id' is required; missing for channel(s)"
        if sub_id is not None and sub_id in self.subs:
            return "subscription id(s) already in use"
        if len(self.subs) >= MAX_SUBSCRIPTIONS:
            return (f"this client holds {MAX_SUBSCRIPTIONS} subscriptions, the most one client "
                    "may (unsubscribe some first); refused")
        if self.per_topic.get(topic, 0) >= MAX_PER_CHANNEL:
            return (f"channel '{topic}' already has {MAX_PER_CHANNEL} subscriptions of this "
                    "client, the most one channel may; refused")
        return None

    def _free_id(self) -> int:
        while self._next_id in self.subs:
            self._next_id += 1
        return self._next_id

    def _add(self, sub_id: int, topic: str) -> None:
        self.subs[sub_id] = topic
        self.per_topic[topic] = self.per_topic.get(topic, 0) + 1

    def _remove(self, sub_id: int) -> str:
        topic = self.subs.pop(sub_id)
        left = self.per_topic[topic] - 1
        if left:
            self.per_topic[topic] = left
        else:
            del self.per_topic[topic]
        return topic

    def _deliver(self, sub_id: int, message: Message) -> None:
        """Called by the bus for every message; must never block or raise."""
        c = self.client
        try:
            message.cdr(c.codec)  # made here first, so a message that cannot be is told once
        except Exception as exc:
            name = message.topic.name
            if name not in self._bad_encodings:
                self._bad_encodings.add(name)
                c.out.status(fg.WARNING, f"topic '{name}': a message could not be encoded as "
                             f"CDR ({exc}); such messages are skipped")
            return
        c.out.data([(DATA.get(message, sub_id), True)], message.topic.name)

    def unsubscribe(self, op: fg.Unsubscribe) -> None:
        unknown = []
        for sub_id in op.subscription_ids:
            if sub_id not in self.subs:
                unknown.append(str(sub_id))
                continue
            self._drop(sub_id)
        self.client.out.errors("unsubscribe: unknown subscription id(s)", unknown)

    def keep_only(self, topics: set[str]) -> None:
        """End the subscriptions to topics no longer advertised."""
        for sub_id, topic in list(self.subs.items()):
            if topic not in topics:
                self._drop(sub_id)

    def drop_topics(self, gone: set[str]) -> None:
        """End the subscriptions to these topics (no longer advertised)."""
        if gone & self.per_topic.keys():
            self.keep_only(set(self.per_topic) - gone)

    def _drop(self, sub_id: int) -> None:
        topic = self._remove(sub_id)
        self.client.bus.unsubscribe(topic, (self.client, sub_id))

    def close(self) -> None:
        for sub_id in list(self.subs):
            self._drop(sub_id)

"""``subscribe`` / ``unsubscribe``: a client's subscriptions to the server's channels. A
message's CDR is encoded once (its ``Encoded``) and each subscriber gets it behind its own
13-byte header."""

from __future__ import annotations

import functools
import itertools
from typing import TYPE_CHECKING

from ...bus.errors import BusError
from ...bus.topics import Message
from ...protocol import foxglove as fg
from ...wire.encoded import Encoded

if TYPE_CHECKING:
    from .context import FoxgloveContext


class SubscribeOps:
    def __init__(self, client: FoxgloveContext, channels: dict[int, str]):
        self.client = client
        self.channels = channels  # the channels advertised to this client (id → topic)
        self.subs: dict[int, str] = {}  # subscription id → topic
        self._bad_encodings: set[str] = set()

    def subscribe(self, op: dict) -> None:
        c = self.client
        given: list[tuple[int, int]] = []
        for sub_id, channel_id in op["subscriptions"]:
            topic = self.channels.get(channel_id)
            if topic is None:
                c.out.status(fg.ERROR, f"subscribe: unknown channel id {channel_id}")
                continue
            if sub_id is None:
                if c.subprotocol == fg.SUBPROTOCOL_V1:
                    c.out.status(fg.ERROR, "subscribe: field 'subscriptions[].id' is required")
                    continue
                sub_id = next(i for i in itertools.count(1) if i not in self.subs)
            if sub_id in self.subs:
                c.out.status(fg.ERROR, f"subscribe: subscription id {sub_id} is already in use")
                continue
            self.subs[sub_id] = topic  # before subscribing: a latched topic delivers at once
            try:
                c.bus.subscribe(topic, None, (c, sub_id), c.node,
                                functools.partial(self._deliver, sub_id))
            except BusError as exc:  # the topic went since it was advertised
                del self.subs[sub_id]
                c.out.status(fg.ERROR, f"subscribe: channel {channel_id}: {exc}")
                continue
            given.append((sub_id, channel_id))
        if c.subprotocol == fg.SUBPROTOCOL_SDK and given:
            c.out.send(fg.subscription_response(given))

    def _deliver(self, sub_id: int, message: Message) -> None:
        """Called by the bus for every message; must never block or raise."""
        c = self.client
        try:
            cdr = message.cdr(c.codec)
        except Exception as exc:
            name = message.topic.name
            if name not in self._bad_encodings:
                self._bad_encodings.add(name)
                c.out.status(fg.WARNING, f"topic '{name}': a message could not be encoded as "
                             f"CDR ({exc}); such messages are skipped")
            return
        encoded = message.wire
        if encoded.__class__ is not Encoded:  # (encoded_of, one call shorter on this path)
            encoded = Encoded(message)
        c.out.data([(encoded.foxglove(sub_id, cdr), True)], message.topic.name)

    def unsubscribe(self, op: dict) -> None:
        for sub_id in op["subscriptionIds"]:
            if sub_id not in self.subs:
                self.client.out.status(fg.ERROR, f"unsubscribe: unknown subscription id {sub_id}")
                continue
            self._drop(sub_id)

    def keep_only(self, topics: set[str]) -> None:
        """End the subscriptions to topics no longer advertised."""
        for sub_id, topic in list(self.subs.items()):
            if topic not in topics:
                self._drop(sub_id)

    def _drop(self, sub_id: int) -> None:
        topic = self.subs.pop(sub_id)
        self.client.bus.unsubscribe(topic, (self.client, sub_id))

    def close(self) -> None:
        for sub_id in list(self.subs):
            self._drop(sub_id)

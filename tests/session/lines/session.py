"""The line protocol (WebSocket subprotocol :data:`SUBPROTOCOL`): ``subscribe TOPIC TYPE`` in,
``subscribed TOPIC`` back, then ``TOPIC JSON`` per message; ``error TEXT`` for a bad line."""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

import orjson

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.errors import BusError
from hitrobot_server.bus.topics import MemoKey, Message
from hitrobot_server.session.outbox import Outbox

SUBPROTOCOL = "hitrobot.lines.v1"


class Lines:
    """The protocol as one server speaks it: its key of the message's memo (one for all its
    sessions, so a message's line is made once, whoever asks) and how many lines it made."""

    def __init__(self, bus: Bus):
        self.bus = bus
        self.made: list[int] = []  # the bus sequence number of each message a line was made of
        self.key: MemoKey[bytes] = MemoKey("lines: a message as one text line", self._line)
        self._ids = itertools.count(1)

    def _line(self, message: Message, _variant: None) -> bytes:
        self.made.append(message.seq)
        return message.topic.name.encode() + b" " + orjson.dumps(message.msg)

    def open(self, peer: str, subprotocol: str) -> LineSession:
        """A new connection's session (a ``SessionFactory`` for ``WireProtocols.register``)."""
        return LineSession(self, peer, f"/lines_client_{next(self._ids)}")


class LineSession:
    """One line client: a ``ClientSession`` (peer, outbox, closed, close_reason, on_close,
    receive, close)."""

    def __init__(self, lines: Lines, peer: str, node: str):
        self.lines = lines
        self.peer = peer
        self.node = node
        self.outbox = Outbox()
        self.closed = False
        self.close_reason = ""
        self.on_close: list[Callable[[Any], None]] = []
        self.topics: list[str] = []
        lines.bus.register_node(node)

    def receive(self, data: str | bytes, binary: bool = False) -> None:
        words = (data.decode() if isinstance(data, bytes) else data).split()
        if len(words) != 3 or words[0] != "subscribe":
            self._send(f"error expected 'subscribe TOPIC TYPE', got {data!r}")
            return
        _, topic, type_name = words
        try:
            self.lines.bus.subscribe(topic, type_name, (self, topic), self.node, self._deliver)
        except BusError as exc:
            self._send(f"error {exc}")
            return
        self.topics.append(topic)
        self._send(f"subscribed {topic}")

    def _deliver(self, message: Message) -> None:
        line = self.lines.key.get(message)  # made once per message, shared by every client
        self.outbox.put([(line, False)], True, message.topic.name)

    def _send(self, text: str) -> None:
        self.outbox.put([(text.encode(), False)])

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        bus = self.lines.bus
        for topic in self.topics:
            bus.unsubscribe(topic, (self, topic))
        bus.unregister_node(self.node)
        self.outbox.close()
        for callback in self.on_close:
            callback(self)
        self.on_close.clear()

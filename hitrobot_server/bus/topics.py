"""Typed topics: publishers, subscribers, latching; a message and its shared encodings."""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable, Hashable
from dataclasses import dataclass

from ..types.registry import MsgType, TypeRegistry
from .encoded import Encoded
from .requests import Reply, Status

log = logging.getLogger(__name__)

_seq = itertools.count(1)


class Message:
    """One published message as every subscriber sees it.

    Its wire encodings are made by whoever needs them first and kept in ``encoded``
    (bus/encoded.py), shared by every subscriber.
    """

    __slots__ = ("topic", "msg", "stamp", "seq", "encoded", "origin", "_status", "_reply")

    def __init__(
        self,
        topic: Topic,
        msg: dict,
        stamp: float,
        reply: Status | None = None,
        origin: Origin | None = None,
    ):
        self.topic = topic
        self.msg = msg
        self.stamp = stamp
        self.seq = next(_seq)
        self.encoded = Encoded(topic, msg, stamp)
        self.origin = origin  # None for in-process publishers
        self._status = reply
        self._reply: Reply | None = None

    @property
    def reply(self) -> Reply:
        """How a node answers the publisher of a request; made when first used, so a plain
        publish never builds one."""
        if self._reply is None:
            self._reply = Reply(self._status)
        return self._reply


Subscriber = Callable[[Message], None]


@dataclass(frozen=True, slots=True)
class Origin:
    """Who published a message: nodes use it to authorise dangerous requests."""

    node: str
    auth_level: str | None = None  # the rosauth level a client authenticated with
    peer: str = ""  # the client's address (host:port), for the recorder's audit channel


class RequestRejected(Exception):
    """Raised by a subscriber callback to refuse a message; the text goes to its publisher."""


class Topic:
    """A named, typed channel. Owners are opaque hashable keys (sessions, node names)."""

    __slots__ = (
        "name",
        "mtype",
        "types",
        "latched",
        "last",
        "publishers",
        "subscribers",
        "_expiry",
    )

    def __init__(self, name: str, mtype: MsgType, types: TypeRegistry, latched: bool = False):
        self.name = name
        self.mtype = mtype
        self.types = types
        self.latched = latched
        self.last: Message | None = None
        self.publishers: dict[Hashable, str] = {}  # owner -> node name
        self.subscribers: dict[Hashable, tuple[str, Subscriber]] = {}  # key -> (node, callback)
        self._expiry = None

    @property
    def type_name(self) -> str:
        return self.mtype.name

    @property
    def idle(self) -> bool:
        return not self.publishers and not self.subscribers

    def fan_out(self, message: Message) -> None:
        """Deliver to every subscriber; one failing callback never starves the others."""
        if self.latched:
            self.last = message
        for key, (_node, callback) in list(self.subscribers.items()):
            try:
                callback(message)
            except RequestRejected as exc:
                message.reply.fail(str(exc))
            except Exception:
                log.exception("subscriber %r of %s failed", key, self.name)

"""Typed topics: publishers, subscribers, latching; a message as every subscriber sees it."""

from __future__ import annotations

import asyncio
import itertools
import logging
from collections.abc import Callable, Hashable, Iterator
from dataclasses import dataclass
from typing import Any, Protocol

from ..types.registry import MsgType, TypeRegistry
from .requests import Reply, Status

log = logging.getLogger(__name__)


class Codec(Protocol):
    """A CDR encoder (``bus.cdr.Ros2Codec``; not imported here: it loads rosbags' store)."""

    def encode(self, msg: dict, mtype: MsgType) -> bytes: ...


class WireMemo(Protocol):
    """A message's other encodings, by typed key (hitrobot_server/wire/memo.py ``Memo``; each
    wire protocol's package owns its keys). The bus holds it and never reads it: it knows no
    wire format."""

    made: dict[Any, Any]
    size: int | None


class Message:
    """One published message as every subscriber sees it.

    Its ROS 2 CDR, what the Zenoh link sends, is made once by whoever needs it first
    (:meth:`cdr`) and shared. Its other encodings are the wire floor's: the bus keeps them in
    ``wire`` without looking, starting from what its publisher handed in (or None).
    """

    __slots__ = ("topic", "msg", "stamp", "seq", "origin", "wire", "cdr_bytes", "_status",
                 "_reply")

    def __init__(
        self,
        topic: Topic,
        msg: dict,
        stamp: float,
        reply: Status | None = None,
        origin: Origin | None = None,
        wire: WireMemo | None = None,
    ):
        self.topic = topic
        self.msg = msg
        self.stamp = stamp
        self.seq = next(topic.seqs)
        self.origin = origin  # None for in-process publishers
        self.wire = wire  # opaque to the bus: the wire floor's encodings of this message
        self.cdr_bytes: bytes | None = None  # its CDR, once encoded or as it arrived (Zenoh)
        self._status = reply
        self._reply: Reply | None = None

    def cdr(self, codec: Codec) -> bytes:
        """ROS 2 CDR, the same bytes for the Zenoh link, every Foxglove client and the
        recorder (``bus.cdr.codec_for`` gives one codec per registry)."""
        data = self.cdr_bytes
        if data is None:
            data = self.cdr_bytes = codec.encode(self.msg, self.topic.mtype)
        return data

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
        "seqs",
        "_expiry",
    )

    def __init__(self, name: str, mtype: MsgType, types: TypeRegistry, latched: bool = False,
                 seqs: Iterator[int] | None = None):
        self.name = name
        self.mtype = mtype
        self.types = types
        self.latched = latched
        self.last: Message | None = None
        self.publishers: dict[Hashable, str] = {}  # owner -> node name
        self.subscribers: dict[Hashable, tuple[str, Subscriber]] = {}  # key -> (node, callback)
        self.seqs = itertools.count(1) if seqs is None else seqs  # numbers its messages (the
        # bus hands every topic its one counter, so a recording's sequence is the bus's)
        self._expiry = None

    @property
    def type_name(self) -> str:
        return self.mtype.name

    @property
    def idle(self) -> bool:
        return not self.publishers and not self.subscribers

    def expire_later(self, timeout: float, expire: Callable[[Topic], None]) -> None:
        """Once unused, ``expire(self)`` after ``timeout`` seconds (at once with none, or with
        no event loop running), unless the topic is used again first (:meth:`keep`)."""
        if not self.idle or self._expiry is not None:
            return
        if timeout <= 0:
            expire(self)
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            expire(self)
            return
        self._expiry = loop.call_later(timeout, self._expired, expire)

    def _expired(self, expire: Callable[[Topic], None]) -> None:
        self._expiry = None
        expire(self)

    def keep(self) -> None:
        """The topic is used again: no expiry."""
        if self._expiry is not None:
            self._expiry.cancel()
            self._expiry = None

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

"""Typed topics: publishers, subscribers, latching; a message as every subscriber sees it.

A message keeps what readers make of it in its :class:`Memo`, by typed :class:`MemoKey`: a
message fanned out to fifty clients is serialised once per encoding, not fifty times (the main
cost rosbridge pays per client, rosbridge #332, #559). The keys are the wire protocols' own
(each declares its keys beside its encoders), so the bus holds the values without knowing any
wire format; a publisher may hand a memo in already filled (``Bus.publish``'s ``seed``).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
from collections.abc import Callable, Hashable, Iterator
from dataclasses import dataclass
from typing import Any, Generic, Protocol, TypeVar

from ..types.registry import MsgType, TypeRegistry
from .requests import Reply, Status

log = logging.getLogger(__name__)
T = TypeVar("T")


class Codec(Protocol):
    """A CDR encoder (``bus.cdr.Ros2Codec``; not imported here: it loads rosbags' store)."""

    def encode(self, msg: dict, mtype: MsgType) -> bytes: ...


class MemoKey(Generic[T]):
    """One kind of encoding of a message: a name (for a reader), and how it is made from the
    message and a variant (a topic spelling, a subscription id, ...) on first use; a key with
    no builder is only ever put by whoever knows its value (a publisher's own text)."""

    __slots__ = ("name", "build")

    def __init__(self, name: str, build: Callable[[Message, Any], T] | None = None) -> None:
        self.name = name
        self.build = build

    def __repr__(self) -> str:
        return f"MemoKey({self.name!r})"

    def get(self, message: Message, variant: Hashable = None) -> T:
        """This encoding of ``message`` in ``variant``, made on the first call, then shared."""
        memo = message.wire
        if memo is None:
            memo = message.wire = Memo()
        made = memo.made  # (one dict look-up on the fan-out path; the key's tuple hashes in C)
        found = made.get((self, variant))
        if found is None:
            if self.build is None:
                raise LookupError(f"{self!r} is only put, never built: peek it")
            found = made[(self, variant)] = self.build(message, variant)
        return found

    def peek(self, message: Message, variant: Hashable = None) -> T | None:
        """This encoding if someone already made it (or the publisher put it), else None."""
        memo = message.wire
        return None if memo is None else memo.made.get((self, variant))

    def put(self, message: Message, value: T, variant: Hashable = None) -> T:
        """Keep ``value`` as this encoding (one made by a caller that needs more than the
        message to make it: a server's frame builder)."""
        memo = message.wire
        if memo is None:
            memo = message.wire = Memo()
        memo.made[(self, variant)] = value
        return value


class Memo:
    """The encodings of one message made so far, by (key, variant), and an estimate of its
    size (as JSON): given by the publisher (the length of the op it came in) or estimated once
    (:func:`size_of`)."""

    __slots__ = ("made", "size")

    def __init__(self, size: int | None = None) -> None:
        self.made: dict[tuple[MemoKey[Any], Hashable], Any] = {}
        self.size = size

    def put(self, key: MemoKey[T], value: T, variant: Hashable = None) -> Memo:
        """What a publisher already has, before the message exists (chainable)."""
        self.made[(key, variant)] = value
        return self


class Message:
    """One published message as every subscriber sees it.

    Its ROS 2 CDR, what the Zenoh link sends, is made once by whoever needs it first
    (:meth:`cdr`) and shared. Its other encodings are in ``wire``, its :class:`Memo` (made on
    first use, or what its publisher handed in).
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
        wire: Memo | None = None,
    ):
        self.topic = topic
        self.msg = msg
        self.stamp = stamp
        self.seq = next(topic.seqs)
        self.origin = origin  # None for in-process publishers
        self.wire = wire  # its memo: what readers made of it, by their keys
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
    name: str = ""  # the name of the token it presented ("" without one)
    role: str = "admin"  # its role: admin without --authenticate, "none" before it signs in


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
        "guard",
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
        self.guard: Subscriber | None = None  # the owning node's: may refuse a message
        # (RequestRejected) before anyone sees it (a robot's drive lease on its /cmd_vel)
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

    def fan_out(self, message: Message) -> bool:
        """Deliver to every subscriber (one failing callback never starves the others) unless
        the topic's guard refuses the message first: then False, and nobody saw it."""
        if self.guard is not None:
            try:
                self.guard(message)
            except RequestRejected as exc:
                message.reply.fail(str(exc))
                return False
        if self.latched:
            self.last = message
        for key, (_node, callback) in list(self.subscribers.items()):
            try:
                callback(message)
            except RequestRejected as exc:
                message.reply.fail(str(exc))
            except Exception:
                log.exception("subscriber %r of %s failed", key, self.name)
        return True

"""Every wire encoding of one bus message, made once and shared by every reader.

A message fanned out to fifty clients is serialised once per (encoding, topic spelling), not
fifty times — the main cost rosbridge pays per client (rosbridge #332, #559). The encodings
of a message are its :class:`Encoded`, which the bus keeps for the wire floor in the
message's opaque ``wire`` slot (:func:`encoded_of` makes it on first use): the JSON body and
publish op, png, cbor, cbor-raw, Foxglove data frames and the frames one subscriber gets
(fragmented or not, built by the server's :class:`~.frames.FrameBuilder`). Each is keyed by a
``Key`` (an :class:`Encoding`, the topic spelling it names, a variant), and each set of frames
is either ready (a list) or :class:`~.frames.PendingFrames`. A message's CDR is the bus's own
(``Message.cdr``: its Zenoh link sends it).
"""

from __future__ import annotations

import functools
from collections.abc import Hashable, Iterable
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

import orjson

from ..bus.topics import Message
from ..protocol import cbor, ops, rawmsg
from ..protocol import foxglove as fg
from ..protocol.bulk import OFFLOAD_BYTES
from ..types import jsoncodec
from ..types.registry import MsgType, TypeRegistry
from .frames import (
    Frame,
    FrameBuilder,
    Frames,
    PendingFrames,
    approx_size,
    as_png,
    cut,
    fragments,
)


class Encoding(IntEnum):
    """What a cached encoding is (an int, so keys hash in C on the fan-out path)."""

    BODY = 0  # the message alone as JSON: the ``msg`` of a publish op
    JSON = 1  # a ``publish`` op as JSON (compression ``none``)
    PNG = 2  # that op as a ``png`` op
    CBOR = 3  # a ``publish`` op as CBOR
    CBOR_RAW = 4  # a ``publish`` op carrying ROS 1 bytes in CBOR
    FOXGLOVE = 6  # a Foxglove message data frame (variant: the subscription id)


_BY_COMPRESSION: dict[str, Encoding] = {
    "none": Encoding.JSON,
    "png": Encoding.PNG,
    "cbor": Encoding.CBOR,
    "cbor-raw": Encoding.CBOR_RAW,
}
"""The encoding each of rosbridge's compressions (``ops.COMPRESSIONS``) asks for."""

_BINARY = frozenset({Encoding.CBOR, Encoding.CBOR_RAW})


Key = tuple[Encoding, str, Hashable]
"""One cached encoding: what it is, for which topic spelling, in which variant (the fragment
size of a subscriber's frames, a Foxglove subscription id). A plain tuple: it is built for
every subscriber of every message, where a class's constructor would cost a third more."""

_BODY: Key = (Encoding.BODY, "", None)


def strongest(compressions: Iterable[str]) -> str:
    """rosbridge's rule when one client subscribes twice: none < png < cbor < cbor-raw."""
    return max(compressions, key=ops.COMPRESSIONS.index, default="none")


def is_binary(compression: str) -> bool:
    """Whether a compression needs binary (WebSocket) frames."""
    return _BY_COMPRESSION[compression] in _BINARY


@dataclass(frozen=True, slots=True)
class Seed:
    """What a publisher already has of a message's encodings: the length of the op it came in
    (its size, near enough) and, when the converter left the message as the client wrote it,
    the client's own ``publish`` op as the outgoing JSON for ``topic``
    (session/rosbridge/publish.py).
    Handed to ``Bus.publish`` (``seed``), which keeps it in the message's ``wire`` slot."""

    size: int
    topic: str = ""
    publish_json: bytes | None = None


def encoded_of(message: Message) -> Encoded:
    """The message's encodings, made on first use (from its publisher's :class:`Seed`, if any).

    A hot path may test ``message.wire.__class__ is Encoded`` itself and call
    ``Encoded(message)`` when it is not: the same, one call shorter."""
    found = message.wire
    if found.__class__ is Encoded:
        return found  # type: ignore[return-value]
    return Encoded(message)


class Encoded:
    """The encodings of one bus message (see the module docstring); pure apart from
    :meth:`frames`, which may start the worker-pool build of a big message's text frames."""

    __slots__ = ("topic", "msg", "stamp", "_bytes", "_frames", "_size", "_client")

    def __init__(self, message: Message):
        """The encodings of ``message``, installed in its ``wire`` slot in place of the
        publisher's :class:`Seed` (what it knew is kept)."""
        self.topic = message.topic
        self.msg = message.msg
        self.stamp = message.stamp
        self._bytes: dict[Key, bytes] = {}
        self._frames: dict[Key, Frames] = {}
        self._size: int | None = None
        self._client: bytes | None = None
        seed = message.wire
        message.wire = self
        if seed is not None:
            self.seed(seed)  # type: ignore[arg-type]

    # ------------------------------------------------------------ what a publisher knows
    def seed(self, seed: Seed) -> None:
        self._size = seed.size
        if seed.publish_json is not None:
            self._bytes[(Encoding.JSON, seed.topic, None)] = self._client = seed.publish_json

    def known(self, encoding: Encoding, topic: str = "") -> bytes | None:
        """An encoding if someone already made it."""
        return self._bytes.get((encoding, topic, None))

    def client_json(self) -> bytes | None:
        """The client's own ``publish`` op when its ``msg`` is the canonical message as it is
        (the publisher's :class:`Seed`), or None: the recorder takes that ``msg`` as is."""
        return self._client

    def size(self) -> int:
        """Estimated JSON size of the body, computed once (or given by the publisher)."""
        if self._size is None:
            self._size = approx_size(self.msg)
        return self._size

    # ------------------------------------------------------------ single encodings
    def publish_json(self, topic: str) -> bytes:
        """``{"op":"publish","topic":T,"msg":…}``, the body serialised once for every spelling."""
        key: Key = (Encoding.JSON, topic, None)
        data = self._bytes.get(key)
        if data is None:
            body = self._bytes.get(_BODY)
            if body is None:
                body = self._bytes[_BODY] = jsoncodec.dumps(self.msg)
            data = self._bytes[key] = publish_json(topic, body)
        return data

    def publish_png(self, topic: str) -> bytes:
        key: Key = (Encoding.PNG, topic, None)
        data = self._bytes.get(key)
        if data is None:
            data = self._bytes[key] = publish_png(topic, self.msg, self.publish_json(topic))
        return data

    def publish_cbor(self, topic: str) -> bytes:
        key: Key = (Encoding.CBOR, topic, None)
        data = self._bytes.get(key)
        if data is None:
            t = self.topic
            data = self._bytes[key] = cbor.encode_publish_cbor(topic, self.msg, t.mtype, t.types)
        return data

    def publish_cbor_raw(self, topic: str) -> bytes:
        key: Key = (Encoding.CBOR_RAW, topic, None)
        data = self._bytes.get(key)
        if data is None:
            secs = int(self.stamp)
            nsecs = int(round((self.stamp - secs) * 1e9))
            t = self.topic
            data = self._bytes[key] = rawmsg.encode_publish_cbor_raw(
                topic, self.msg, t.mtype, t.types, (secs, nsecs)
            )
        return data

    def foxglove(self, sub_id: int, cdr: bytes) -> bytes:
        """The Foxglove message data frame of subscription ``sub_id`` around ``cdr`` (the
        message's ``Message.cdr``)."""
        key: Key = (Encoding.FOXGLOVE, "", sub_id)
        data = self._bytes.get(key)
        if data is None:
            data = self._bytes[key] = fg.message_data(sub_id, fg.nanoseconds(self.stamp), cdr)
        return data

    # ------------------------------------------------------------ a subscriber's frames
    def frames(
        self, topic: str, compression: str, fragment_size: int | None, builder: FrameBuilder
    ) -> Frames:
        """The frames one subscriber gets; fragments only text ops and only when asked to.

        Made once per (compression, topic spelling, fragment size) and shared by every such
        subscriber. A big message with variable arrays, for a text compression, is built by
        the builder's runner (when it has one) and is pending until its frames are back.
        """
        encoding = _BY_COMPRESSION[compression]
        key: Key = (encoding, topic, fragment_size)
        found = self._frames.get(key)
        if found is not None:
            if isinstance(found, PendingFrames) and found.ok():
                found = self._frames[key] = found.future.result()
            return found
        if encoding is Encoding.CBOR:
            found = [(self.publish_cbor(topic), True)]
        elif encoding is Encoding.CBOR_RAW:
            found = [(self.publish_cbor_raw(topic), True)]
        elif (
            builder.offload is not None
            and (Encoding.JSON, topic, None) not in self._bytes
            and has_lists(self.topic.mtype, self.topic.types)
            and self.size() >= OFFLOAD_BYTES
        ):
            found = builder.offloaded(
                self.size(), publish_frames_taken, topic, [self.msg], compression, fragment_size
            )
        else:
            data = self.publish_png(topic) if encoding is Encoding.PNG else self.publish_json(topic)
            if fragment_size and len(data) > fragment_size:
                found = fragments(data, fragment_size, builder.ids.next())
            else:
                found = [(data, False)]
        self._frames[key] = found
        return found


# ------------------------------------------------------------ pure publish-op encoders
@functools.lru_cache(maxsize=1024)
def publish_head(topic: str) -> bytes:
    return b'{"op":"publish","topic":' + orjson.dumps(topic) + b',"msg":'


def publish_json(topic: str, msg_json: bytes) -> bytes:
    """``{"op":"publish","topic":T,"msg":…}`` around an already serialised body."""
    return b"".join((publish_head(topic), msg_json, b"}"))


def publish_png(topic: str, msg: dict, op_json: bytes) -> bytes:
    """The ``png`` op of a publish whose JSON text is ``op_json``."""
    return as_png(op_json, {"op": "publish", "topic": topic, "msg": msg})


def publish_frames(
    topic: str, msg: dict, compression: str, fragment_size: int | None, frag_id: str
) -> list[Frame]:
    """Every frame one text subscriber (``none`` or ``png``) gets for one message: what the
    worker pool builds for a big one, byte for byte what :meth:`Encoded.frames` makes."""
    # the whole op in one dump (the bytes publish_json makes): joining a head to a 50 MB
    # body would hold both at once in the worker
    data = jsoncodec.dumps({"op": "publish", "topic": topic, "msg": msg})
    if compression == "png":
        data = publish_png(topic, msg, data)
    return cut(data, fragment_size, frag_id)


def publish_frames_taken(
    topic: str, box: list[dict], compression: str, fragment_size: int | None, frag_id: str
) -> list[Frame]:
    """:func:`publish_frames` of the message in ``box``, taken out of it: the worker pool keeps
    a call's arguments until its answer is sent, so a message passed as is would still be held
    while its frames are pickled back (a 10 MB typed array widened to 20 MB of float64); taken
    out of the box, it is freed before."""
    msg = box.pop()
    frames = publish_frames(topic, msg, compression, fragment_size, frag_id)
    del msg
    return frames


def has_lists(mtype: MsgType, reg: TypeRegistry) -> bool:
    """Whether a message of this type can hold a variable-length array (at any depth); one
    that cannot (Twist, Odometry, String, ...) is never big enough to leave the event loop."""
    memo: dict[str, Any] = reg.plans["has_lists"]
    found = memo.get(mtype.name)
    if found is None:
        memo[mtype.name] = False  # a recursive type cannot loop forever here
        found = memo[mtype.name] = any(
            f.array == 0 or (f.is_msg and has_lists(reg.msg(f.type), reg)) for f in mtype.fields
        )
    return found

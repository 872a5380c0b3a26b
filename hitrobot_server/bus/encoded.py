"""Every wire encoding of one bus message, made once and shared by every reader.

A message fanned out to fifty clients is serialised once per (encoding, topic spelling), not
fifty times — the main cost rosbridge pays per client (rosbridge #332, #559). The encodings
live here, on the message (``Message.encoded``): the JSON body and publish op, png, cbor,
cbor-raw, ROS 2 CDR (Foxglove, the Zenoh link, the recorder), Foxglove data frames and the
frames one subscriber gets (fragmented or not). Each is keyed by a ``Key`` (an
:class:`Encoding`, the topic spelling it names, a variant), and each set of frames is either
ready (a list) or :class:`PendingFrames`: a big message's text frames are built in the worker
pool (the session passes its runner), and the outbox waits for them in place.
"""

from __future__ import annotations

import asyncio
import functools
import logging
from collections.abc import Awaitable, Callable, Hashable, Iterable
from dataclasses import dataclass
from enum import IntEnum
from typing import TYPE_CHECKING, Any, Protocol

import orjson

from ..protocol import bulk, cbor, ops, png, rawmsg
from ..protocol import foxglove as fg
from ..protocol.bulk import Frame
from ..protocol.fragment import FragmentIds
from ..types import jsoncodec
from ..types.registry import MsgType, TypeRegistry

if TYPE_CHECKING:
    from .topics import Topic

log = logging.getLogger(__name__)

fragment_ids = FragmentIds()
"""One counter for every fragmented op this process sends (topic data and replies alike), so
two groups of fragments on one connection never share an id."""

Run = Callable[..., Awaitable[list[Frame]]]
"""Runs ``fn(*args)`` away from the event loop (``session.offload.run``: the worker pool)."""


class Encoding(IntEnum):
    """What a cached encoding is (an int, so keys hash in C on the fan-out path)."""

    BODY = 0  # the message alone as JSON: the ``msg`` of a publish op
    JSON = 1  # a ``publish`` op as JSON (compression ``none``)
    PNG = 2  # that op as a ``png`` op
    CBOR = 3  # a ``publish`` op as CBOR
    CBOR_RAW = 4  # a ``publish`` op carrying ROS 1 bytes in CBOR
    CDR = 5  # the message as ROS 2 CDR (no topic: the same bytes for every reader)
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
_CDR: Key = (Encoding.CDR, "", None)


def strongest(compressions: Iterable[str]) -> str:
    """rosbridge's rule when one client subscribes twice: none < png < cbor < cbor-raw."""
    return max(compressions, key=ops.COMPRESSIONS.index, default="none")


def is_binary(compression: str) -> bool:
    """Whether a compression needs binary (WebSocket) frames."""
    return _BY_COMPRESSION[compression] in _BINARY


class PendingFrames:
    """Frames being built away from the event loop, and the bytes they are charged at until
    then (an estimate). A queue holding one waits for it in place."""

    __slots__ = ("future", "size")

    def __init__(self, future: asyncio.Future[list[Frame]], size: int):
        self.future = future
        self.size = size

    def done(self) -> bool:
        return self.future.done()

    def ok(self) -> bool:
        """Done, with frames (not failed, not cancelled)."""
        f = self.future
        return f.done() and not f.cancelled() and f.exception() is None

    def frames(self) -> list[Frame] | None:
        """The frames once done; None (logged) when building them failed or was cancelled."""
        if self.future.cancelled():
            return None
        exc = self.future.exception()
        if exc is not None:
            log.error("encoding a big message failed; it is skipped for this client: %r", exc)
            return None
        return self.future.result()


Frames = list[Frame] | PendingFrames
"""One message's or reply's frames as a queue holds them: ready, or pending."""


@dataclass(frozen=True, slots=True)
class Seed:
    """What a publisher already has of a message's encodings: the length of the op it came in
    (its size, near enough) and, when the converter left the message as the client wrote it,
    the client's own ``publish`` op as the outgoing JSON for ``topic`` (session/publish.py)."""

    size: int
    topic: str = ""
    publish_json: bytes | None = None


class Codec(Protocol):
    """A CDR encoder (``bus.cdr.Ros2Codec``; not imported here: it loads rosbags' store)."""

    def encode(self, msg: dict, mtype: MsgType) -> bytes: ...


class Encoded:
    """The encodings of one bus message (see the module docstring); pure apart from
    :meth:`frames`, which starts the worker-pool build of a big message's text frames."""

    __slots__ = ("topic", "msg", "stamp", "_bytes", "_frames", "_size")

    def __init__(self, topic: Topic, msg: dict, stamp: float):
        self.topic = topic
        self.msg = msg
        self.stamp = stamp
        self._bytes: dict[Key, bytes] = {}
        self._frames: dict[Key, Frames] = {}
        self._size: int | None = None

    # ------------------------------------------------------------ what a publisher knows
    def seed(self, seed: Seed) -> None:
        self._size = seed.size
        if seed.publish_json is not None:
            self._bytes[(Encoding.JSON, seed.topic, None)] = seed.publish_json

    def known(self, encoding: Encoding, topic: str = "") -> bytes | None:
        """An encoding if someone already made it (the recorder writes CDR it finds)."""
        return self._bytes.get((encoding, topic, None))

    def size(self) -> int:
        """Estimated JSON size of the body, computed once (or given by the publisher)."""
        if self._size is None:
            self._size = bulk.approx_size(self.msg)
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

    def cdr(self, codec: Codec) -> bytes:
        """ROS 2 CDR, the same bytes for the Zenoh link, every Foxglove client and the
        recorder (``bus.cdr.codec_for`` gives one codec per registry)."""
        data = self._bytes.get(_CDR)
        if data is None:
            data = self._bytes[_CDR] = codec.encode(self.msg, self.topic.mtype)
        return data

    def received_cdr(self, payload: bytes) -> None:
        """The message arrived as these CDR bytes (Zenoh): readers reuse them as they are."""
        self._bytes[_CDR] = payload

    def foxglove(self, sub_id: int, cdr: bytes) -> bytes:
        """The Foxglove message data frame of subscription ``sub_id`` around ``cdr``."""
        key: Key = (Encoding.FOXGLOVE, "", sub_id)
        data = self._bytes.get(key)
        if data is None:
            data = self._bytes[key] = fg.message_data(sub_id, fg.nanoseconds(self.stamp), cdr)
        return data

    # ------------------------------------------------------------ a subscriber's frames
    def frames(
        self, topic: str, compression: str, fragment_size: int | None, offload: Run | None = None
    ) -> Frames:
        """The frames one subscriber gets; fragments only text ops and only when asked to.

        Made once per (compression, topic spelling, fragment size) and shared by every such
        subscriber. A big message with variable arrays, for a text compression, is built by
        ``offload`` (when given) and is :class:`PendingFrames` until its frames are back.
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
            offload is not None
            and (Encoding.JSON, topic, None) not in self._bytes
            and has_lists(self.topic.mtype, self.topic.types)
            and self.size() >= bulk.OFFLOAD_BYTES
        ):
            found = self._offloaded(offload, topic, compression, fragment_size)
        else:
            data = self.publish_png(topic) if encoding is Encoding.PNG else self.publish_json(topic)
            if fragment_size and len(data) > fragment_size:
                found = bulk.fragments(data, fragment_size, fragment_ids.next())
            else:
                found = [(data, False)]
        self._frames[key] = found
        return found

    def _offloaded(
        self, offload: Run, topic: str, compression: str, fragment_size: int | None
    ) -> PendingFrames:
        frag_id = fragment_ids.next()
        future = asyncio.ensure_future(
            offload(publish_frames, topic, self.msg, compression, fragment_size, frag_id)
        )
        return PendingFrames(future, self.size())


# ------------------------------------------------------------ pure publish-op encoders
@functools.lru_cache(maxsize=1024)
def _publish_head(topic: str) -> bytes:
    return b'{"op":"publish","topic":' + orjson.dumps(topic) + b',"msg":'


def publish_json(topic: str, msg_json: bytes) -> bytes:
    """``{"op":"publish","topic":T,"msg":…}`` around an already serialised body."""
    return b"".join((_publish_head(topic), msg_json, b"}"))


VERBATIM_MIN = 2048
"""Publish ops shorter than this are re-encoded: checking the text costs about 2 us, encoding
a 2 kB message about as much, a 14 kB LaserScan 12 us."""


def verbatim_publish(text: str | bytes, op: dict) -> bytes | None:
    """The outgoing ``publish`` op cut from the client's own ``publish`` text, or None.

    Only for a message the converter left as it was (``from_json_verbatim``): then the text
    of its ``msg`` already is its JSON, and re-encoding it would be wasted work (a third of
    the cost of relaying a LaserScan). The keys around ``msg`` are re-serialised and must
    match the text exactly, so whatever sits between them is the ``msg`` value as parsed
    (with duplicate keys, a last-wins parser reads exactly what was validated); NaN/Infinity
    literals, which only the lenient fallback parser accepts, are never passed on.
    """
    data = text.encode() if type(text) is str else text
    keys = list(op)
    if keys == ["op", "topic", "msg"]:  # the op already is {"op":"publish","topic":T,"msg":…}
        head, tail = _publish_head(op["topic"]), b"}"
    else:  # e.g. roslibjs: {"op","id","topic","msg","latch"}
        at = keys.index("msg")
        head = b"{" + b"".join(_member(k, op[k]) + b"," for k in keys[:at]) + b'"msg":'
        tail = b"".join(b"," + _member(k, op[k]) for k in keys[at + 1 :]) + b"}"
    if not (data.startswith(head) and data.endswith(tail)) or len(data) < len(head) + len(tail):
        return None
    if (b"N" in data and b"NaN" in data) or (b"I" in data and b"Infinity" in data):
        return None  # (one byte is a memchr; the 3-byte search costs 10 us on a LaserScan)
    if tail == b"}" and head == _publish_head(op["topic"]):
        return data
    return publish_json(op["topic"], data[len(head) : len(data) - len(tail)])


def _member(key: str, value: object) -> bytes:
    return orjson.dumps(key) + b":" + orjson.dumps(value)


def publish_png(topic: str, msg: dict, op_json: bytes) -> bytes:
    """The ``png`` op of a publish whose JSON text is ``op_json``."""
    if not op_json.isascii():  # roslibjs 1.x decodes png pixels as Latin-1
        op_json = jsoncodec.dumps_ascii({"op": "publish", "topic": topic, "msg": msg})
    return png.png_op(op_json)


def publish_frames(
    topic: str, msg: dict, compression: str, fragment_size: int | None, frag_id: str
) -> list[Frame]:
    """Every frame one text subscriber (``none`` or ``png``) gets for one message: what the
    worker pool builds for a big one, byte for byte what :meth:`Encoded.frames` makes."""
    data = publish_json(topic, jsoncodec.dumps(msg))
    if compression == "png":
        data = publish_png(topic, msg, data)
    if fragment_size and len(data) > fragment_size:
        return bulk.fragments(data, fragment_size, frag_id)
    return [(data, False)]


def has_lists(mtype: MsgType, reg: TypeRegistry) -> bool:
    """Whether a message of this type can hold a variable-length array (at any depth); one
    that cannot (Twist, Odometry, String, ...) is never big enough to leave the event loop."""
    memo: dict[str, Any] = reg.plan_cache("has_lists")
    found = memo.get(mtype.name)
    if found is None:
        memo[mtype.name] = False  # a recursive type cannot loop forever here
        found = memo[mtype.name] = any(
            f.array == 0 or (f.is_msg and has_lists(reg.msg(f.type), reg)) for f in mtype.fields
        )
    return found

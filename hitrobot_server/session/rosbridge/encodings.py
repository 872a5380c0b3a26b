"""rosbridge's encodings of a bus message, each made once and shared by every subscriber.

Each is a typed key of the message's memo (hitrobot_server/bus/topics.py): the JSON body, the
``publish`` op as JSON, png, cbor and cbor-raw for each topic spelling (a client's ``publish``
echoes the topic as it wrote it), and the frames one subscriber gets (per compression, topic
spelling and fragment size), ready (a list) or ``PendingFrames`` while the worker pool builds a
big message's (:func:`subscriber_frames`). A client's own ``publish`` op is put in the memo by its
publisher (:func:`seeded`) as the outgoing JSON for its spelling.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable
from typing import Any

import orjson

from ...bus.topics import Memo, MemoKey, Message
from ...protocol import cbor, ops, rawmsg
from ...protocol.bulk import OFFLOAD_BYTES
from ...types import jsoncodec
from ...types.generation import is_ros2, ros2_times
from ...types.registry import MsgType, TypeRegistry
from ...wire.frames import Frame, Frames, PendingFrames
from ...wire.memo import PUBLISHED_JSON, size_of
from .frames import FrameBuilder, as_png, cut, fragments


def json_msg(message: Message) -> dict:
    """The message as a JSON client gets it: a ROS 2 type's times as ROS 2 spells them."""
    t = message.topic
    return ros2_times(message.msg, t.mtype, t.types) if is_ros2(t.mtype.name) else message.msg


def _body(message: Message, _variant: None) -> bytes:
    return jsoncodec.dumps(json_msg(message))


def _publish_json(message: Message, topic: str) -> bytes:
    return publish_json(topic, BODY.get(message))


def _publish_png(message: Message, topic: str) -> bytes:
    return publish_png(topic, json_msg(message), PUBLISH_JSON.get(message, topic))


def _publish_cbor(message: Message, topic: str) -> bytes:
    t = message.topic
    return cbor.encode_publish_cbor(topic, message.msg, t.mtype, t.types)


def _publish_cbor_raw(message: Message, topic: str) -> bytes:
    secs = int(message.stamp)
    nsecs = int(round((message.stamp - secs) * 1e9))
    t = message.topic
    return rawmsg.encode_publish_cbor_raw(topic, message.msg, t.mtype, t.types, (secs, nsecs))


BODY: MemoKey[bytes] = MemoKey("rosbridge: the message as JSON", _body)
"""The message alone as JSON: the ``msg`` of a publish op, one for every spelling."""
PUBLISH_JSON: MemoKey[bytes] = MemoKey("rosbridge: publish op, JSON", _publish_json)
"""``{"op":"publish","topic":T,"msg":…}``; variant: the topic spelling T."""
PUBLISH_PNG: MemoKey[bytes] = MemoKey("rosbridge: publish op, png", _publish_png)
PUBLISH_CBOR: MemoKey[bytes] = MemoKey("rosbridge: publish op, cbor", _publish_cbor)
PUBLISH_CBOR_RAW: MemoKey[bytes] = MemoKey("rosbridge: publish op, cbor-raw", _publish_cbor_raw)

_FRAMES: dict[str, MemoKey[Frames]] = {
    compression: MemoKey(f"rosbridge: a subscriber's frames, {compression}")
    for compression in ops.COMPRESSIONS
}
"""The frames of one subscriber per compression (variant: topic spelling, fragment size);
put by :func:`subscriber_frames`, which needs the server's frame builder to make them."""
_BINARY = {"none": False, "png": False, "cbor": True, "cbor-raw": True}


def strongest(compressions: Iterable[str]) -> str:
    """rosbridge's rule when one client subscribes twice: none < png < cbor < cbor-raw."""
    return max(compressions, key=ops.COMPRESSIONS.index, default="none")


def is_binary(compression: str) -> bool:
    """Whether a compression needs binary (WebSocket) frames."""
    return _BINARY[compression]


def seeded(size: int, topic: str, publish_json: bytes | None = None) -> Memo:
    """What a publisher hands ``Bus.publish`` (``seed``): the length of the op the message came
    in (its size, near enough) and, when the converter left the message as the client wrote it,
    the client's own ``publish`` op: the outgoing JSON for ``topic``, and the publisher's JSON
    the recorder takes (session/rosbridge/publish.py)."""
    memo = Memo(size)
    if publish_json is not None:
        memo.put(PUBLISH_JSON, publish_json, topic).put(PUBLISHED_JSON, publish_json)
    return memo


def subscriber_frames(message: Message, topic: str, compression: str,
                      fragment_size: int | None, builder: FrameBuilder) -> Frames:
    """The frames one subscriber gets; fragments only text ops and only when asked to.

    Made once per (compression, topic spelling, fragment size) and shared by every such
    subscriber. A big message with variable arrays, for a text compression, is built by the
    builder's runner (when it has one) and is pending until its frames are back.
    """
    key = _FRAMES[compression]
    variant = (topic, fragment_size)
    found = key.peek(message, variant)
    if found is not None:
        if found.__class__ is PendingFrames and found.ok():  # type: ignore[union-attr]
            found = key.put(message, found.future.result(), variant)  # type: ignore[union-attr]
        return found
    if compression == "cbor":
        found = [(PUBLISH_CBOR.get(message, topic), True)]
    elif compression == "cbor-raw":
        found = [(PUBLISH_CBOR_RAW.get(message, topic), True)]
    elif (
        builder.offload is not None
        and has_lists(message.topic.mtype, message.topic.types)
        and PUBLISH_JSON.peek(message, topic) is None  # (made already: cutting it is cheap)
        and size_of(message) >= OFFLOAD_BYTES
    ):
        found = builder.offloaded(size_of(message), publish_frames_taken, topic,
                                  [json_msg(message)],
                                  compression, fragment_size)
    else:
        key_of = PUBLISH_PNG if compression == "png" else PUBLISH_JSON
        data = key_of.get(message, topic)
        if fragment_size and len(data) > fragment_size:
            found = fragments(data, fragment_size, builder.ids.next())
        else:
            found = [(data, False)]
    return key.put(message, found, variant)


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
    worker pool builds for a big one, byte for byte what :func:`subscriber_frames` makes."""
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

"""Outgoing wire encodings of bus messages, cached on the message for every subscriber.

A big message (``offload.OFFLOAD_BYTES`` or more) is encoded for text subscribers in the worker
pool: its entry in the cache is then a future of the frames, which the outbox awaits in order.
"""

from __future__ import annotations

import asyncio
import logging

from ..bus.topics import Message
from ..protocol import bulk, cbor, rawmsg
from ..protocol.fragment import FragmentIds
from ..protocol.ops import COMPRESSIONS
from ..types import jsoncodec
from ..types.registry import MsgType, TypeRegistry
from . import offload
from .outbox import Frame, Frames

log = logging.getLogger(__name__)
_BINARY = {"cbor", "cbor-raw"}
_fragment_ids = FragmentIds()


def strongest(compressions) -> str:
    """rosbridge's rule when one client subscribes twice: none < png < cbor < cbor-raw."""
    return max(compressions, key=COMPRESSIONS.index, default="none")


def _msg_json(message: Message) -> bytes:
    return message.cached("json", lambda: jsoncodec.dumps(message.msg))


def publish_json(message: Message, topic: str) -> bytes:
    """``{"op":"publish","topic":T,"msg":…}`` with the message body serialised once."""
    data = message.cache.get(("json", topic))
    if data is None:
        data = message.cache["json", topic] = bulk.publish_json(topic, _msg_json(message))
    return data


def publish_png(message: Message, topic: str) -> bytes:
    return message.cached(
        ("png", topic),
        lambda: bulk.publish_png(topic, message.msg, publish_json(message, topic)),
    )


def publish_cbor(message: Message, topic: str) -> bytes:
    topic_obj = message.topic
    return message.cached(
        ("cbor", topic),
        lambda: cbor.encode_publish_cbor(topic, message.msg, topic_obj.mtype, message.topic.types),
    )


def publish_cbor_raw(message: Message, topic: str) -> bytes:
    secs = int(message.stamp)
    nsecs = int(round((message.stamp - secs) * 1e9))
    return message.cached(
        ("cbor-raw", topic),
        lambda: rawmsg.encode_publish_cbor_raw(
            topic, message.msg, message.topic.mtype, message.topic.types, (secs, nsecs)
        ),
    )


def has_lists(mtype: MsgType, reg: TypeRegistry) -> bool:
    """Whether a message of this type can hold a variable-length array (at any depth); one
    that cannot (Twist, Odometry, String, ...) is never big enough to leave the event loop."""
    memo = reg.plan_cache("has_lists")
    found = memo.get(mtype.name)
    if found is None:
        memo[mtype.name] = False  # a recursive type cannot loop forever here
        found = memo[mtype.name] = any(
            f.array == 0 or (f.is_msg and has_lists(reg.msg(f.type), reg)) for f in mtype.fields
        )
    return found


def message_size(message: Message) -> int:
    """Estimated JSON size of the message body, computed once per message (or given by the
    publisher: the length of the op it came in)."""
    size = message.cache.get("size")
    if size is None:
        size = message.cache["size"] = offload.approx_size(message.msg)
    return size


def publish_frames(
    message: Message, topic: str, compression: str, fragment_size: int | None
) -> Frames:
    """The frames one subscriber gets; fragments only text ops and only when asked to.

    Computed once per (compression, topic spelling, fragment size) and shared by every such
    subscriber. For a big message and a text compression this is a future of the frames, or
    its result once it is done.
    """
    key = (compression, topic, fragment_size)
    frames = message.cache.get(key)
    if frames is None:
        frames = message.cache[key] = _frames(message, topic, compression, fragment_size)
    if type(frames) is list:
        return frames
    if frames.done() and not frames.cancelled() and frames.exception() is None:
        return frames.result()
    return frames


def _frames(message: Message, topic: str, compression: str, fragment_size: int | None) -> Frames:
    if compression == "cbor":
        return [(publish_cbor(message, topic), True)]
    if compression == "cbor-raw":
        return [(publish_cbor_raw(message, topic), True)]
    if (
        ("json", topic) not in message.cache
        and has_lists(message.topic.mtype, message.topic.types)
        and message_size(message) >= offload.OFFLOAD_BYTES
    ):
        return _offloaded(message, topic, compression, fragment_size)
    data = publish_png(message, topic) if compression == "png" else publish_json(message, topic)
    if fragment_size and len(data) > fragment_size:
        return fragment_frames(data, fragment_size, None)
    return [(data, False)]


def _offloaded(
    message: Message, topic: str, compression: str, fragment_size: int | None
) -> asyncio.Future[list[Frame]]:
    frag_id = _fragment_ids.next()
    return asyncio.ensure_future(
        offload.run(bulk.publish_frames, topic, message.msg, compression, fragment_size, frag_id)
    )


def fragment_frames(data: bytes, size: int, op_id: object) -> list[Frame]:
    """Split encoded JSON into ``fragment`` ops with a fresh, non-empty string id."""
    return bulk.fragments(data, size, _fragment_ids.next(op_id))


def json_frames(
    obj: dict, fragment_size: int | None = None, compression: str = "none"
) -> list[Frame]:
    """Frames for a reply op (service_response, action_result, status, ...)."""
    data = bulk.reply_data(obj, compression)
    if fragment_size and len(data) > fragment_size:
        return fragment_frames(data, fragment_size, obj.get("id"))
    return [(data, False)]


def reply_frames(obj: dict, fragment_size: int | None, compression: str) -> Frames:
    """Frames for a reply op; a big one that is fragmented or png-compressed is built in the
    worker pool (a future of its frames), so cutting it up never holds the event loop."""
    if not (fragment_size or compression == "png") or (
        offload.approx_size(obj) < offload.OFFLOAD_BYTES
    ):
        return json_frames(obj, fragment_size, compression)
    return asyncio.ensure_future(_offloaded_reply(obj, fragment_size, compression))


async def _offloaded_reply(obj: dict, fragment_size: int | None, compression: str) -> list[Frame]:
    frag_id = _fragment_ids.next(obj.get("id"))
    try:
        return await offload.run(bulk.reply_frames, obj, fragment_size, compression, frag_id)
    except Exception:  # the pool broke: the reply is still owed, built here this once
        log.exception("building a big reply in the worker pool failed; built inline")
        return json_frames(obj, fragment_size, compression)


def is_binary(compression: str) -> bool:
    return compression in _BINARY

"""Outgoing wire encodings of bus messages, cached on the message for every subscriber."""

from __future__ import annotations

from ..bus.topics import Message
from ..protocol import cbor, png, rawmsg
from ..protocol.fragment import FragmentIds, fragment_bytes
from ..protocol.ops import COMPRESSIONS
from ..types import jsoncodec
from .outbox import Frame

_BINARY = {"cbor", "cbor-raw"}
_fragment_ids = FragmentIds()


def strongest(compressions) -> str:
    """rosbridge's rule when one client subscribes twice: none < png < cbor < cbor-raw."""
    return max(compressions, key=COMPRESSIONS.index, default="none")


def _msg_json(message: Message) -> bytes:
    return message.cached("json", lambda: jsoncodec.dumps(message.msg))


def publish_json(message: Message, topic: str) -> bytes:
    """``{"op":"publish","topic":T,"msg":…}`` with the message body serialised once."""

    def make() -> bytes:
        return b"".join(
            (
                b'{"op":"publish","topic":',
                jsoncodec.dumps(topic),
                b',"msg":',
                _msg_json(message),
                b"}",
            )
        )

    return message.cached(("json", topic), make)


def publish_png(message: Message, topic: str) -> bytes:
    def make() -> bytes:
        text = publish_json(message, topic)
        if not text.isascii():  # roslibjs 1.x decodes png pixels as Latin-1
            text = jsoncodec.dumps_ascii({"op": "publish", "topic": topic, "msg": message.msg})
        return png.png_op(text)

    return message.cached(("png", topic), make)


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


def publish_frames(
    message: Message, topic: str, compression: str, fragment_size: int | None
) -> list[Frame]:
    """The frames one subscriber gets; fragments only text ops and only when asked to."""
    if compression == "cbor":
        return [(publish_cbor(message, topic), True)]
    if compression == "cbor-raw":
        return [(publish_cbor_raw(message, topic), True)]
    data = publish_png(message, topic) if compression == "png" else publish_json(message, topic)
    if fragment_size and len(data) > fragment_size:
        key = ("frag", compression, topic, fragment_size)
        return message.cached(key, lambda: fragment_frames(data, fragment_size, None))
    return [(data, False)]


def fragment_frames(data: bytes, size: int, op_id: object) -> list[Frame]:
    """Split encoded JSON into ``fragment`` ops with a fresh, non-empty string id."""
    frag_id = _fragment_ids.next(op_id)
    return [(frame, False) for frame in fragment_bytes(data.decode(), size, frag_id)]


def json_frames(
    obj: dict, fragment_size: int | None = None, compression: str = "none"
) -> list[Frame]:
    """Frames for a reply op (service_response, action_result, status, ...)."""
    data = jsoncodec.dumps(obj)
    if compression == "png":
        if not data.isascii():
            data = jsoncodec.dumps_ascii(obj)
        data = png.png_op(data)
    if fragment_size and len(data) > fragment_size:
        return fragment_frames(data, fragment_size, obj.get("id"))
    return [(data, False)]


def is_binary(compression: str) -> bool:
    return compression in _BINARY

"""The one frame builder of rosbridge: an op (a published message's ``publish`` op or a
reply) as the frames a client gets — JSON or png, whole or cut into ``fragment`` ops.

Frames are ready (a list) or ``PendingFrames`` (hitrobot_server/wire/frames.py): a big op's
frames are built in the worker pool (the :class:`FrameBuilder`'s runner), and the outbox waits
for them in place. The pure builders (:func:`reply_frames` here, ``encodings.publish_frames``
for a message) are also what the worker runs, so an offloaded op is byte for byte what the
inline path sends. A bus message's encodings, shared by every subscriber, are its memo's, by
the keys of :mod:`.encodings`.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable

from ...protocol import png
from ...protocol.bulk import OFFLOAD_BYTES
from ...protocol.errors import MessageId
from ...protocol.fragment import FragmentIds, fragment_bytes, fragment_size_for
from ...types import jsoncodec
from ...wire.frames import Frame, Frames, PendingFrames, Run
from ...wire.memo import approx_size

log = logging.getLogger(__name__)


# ------------------------------------------------------------ pure builders (also the worker's)
def fragments(data: bytes, size: int, frag_id: str) -> list[Frame]:
    """Encoded JSON split into ``fragment`` ops with the id ``frag_id``, in pieces of ``size``
    characters or as many more as the bounds of ``protocol.fragment.fragment_size_for``
    need."""
    text = data.decode()
    size = fragment_size_for(len(text), size)
    return [(frame, False) for frame in fragment_bytes(text, size, frag_id)]


def cut(data: bytes, fragment_size: int | None, frag_id: str) -> list[Frame]:
    """One encoded text op as frames: whole, or fragments when longer than ``fragment_size``."""
    if fragment_size and len(data) > fragment_size:
        return fragments(data, fragment_size, frag_id)
    return [(data, False)]


def as_png(data: bytes, op: dict) -> bytes:
    """The ``png`` op around the JSON text ``data`` of ``op``; roslibjs 1.x decodes png pixels
    as Latin-1, so a text that is not ASCII is encoded again with escapes."""
    if not data.isascii():
        data = jsoncodec.dumps_ascii(op)
    return png.png_op(data)


def reply_data(obj: dict, compression: str = "none") -> bytes:
    """A reply op (service_response, action_result, status, ...) as one JSON or png frame."""
    data = jsoncodec.dumps(obj)
    return as_png(data, obj) if compression == "png" else data


def reply_frames(obj: dict, fragment_size: int | None, compression: str,
                 frag_id: str) -> list[Frame]:
    """Every frame of one reply op; what the worker builds for a big one."""
    return cut(reply_data(obj, compression), fragment_size, frag_id)


def json_frames(obj: dict) -> list[Frame]:
    """A reply op as one JSON frame (a status: never cut, never offloaded)."""
    return [(jsoncodec.dumps(obj), False)]


# ------------------------------------------------------------ the builder
class FrameBuilder:
    """Builds the frames of every op a server's rosbridge clients get, a published message's
    (``encodings.subscriber_frames``) and a reply's alike. One per server: its fragment ids
    come from one counter, so two groups of fragments on one connection never share an id,
    whether they carry topic data (built once, shared by every subscriber) or a reply."""

    def __init__(self, offload: Run | None = None) -> None:
        self.ids = FragmentIds()
        self.offload = offload  # None: everything is built inline

    def cut(self, data: bytes, fragment_size: int | None, op_id: MessageId = None
            ) -> list[Frame]:
        """An encoded text op as frames, fragments with a fresh id when longer than
        ``fragment_size``."""
        if fragment_size and len(data) > fragment_size:
            return fragments(data, fragment_size, self.ids.next(op_id))
        return [(data, False)]

    def offloaded(self, size: int, fn: Callable[..., list[Frame]], *args: object
                  ) -> PendingFrames:
        """``fn(*args, frag_id)`` built by the runner, charged at ``size`` until it is done."""
        assert self.offload is not None
        future = asyncio.ensure_future(self.offload(fn, *args, self.ids.next()))
        return PendingFrames(future, size)

    def reply(self, obj: dict, fragment_size: int | None = None,
              compression: str = "none") -> Frames:
        """Frames for a reply op; a big one that is fragmented or png-compressed is built by
        the runner (pending), so cutting it up never holds the event loop."""
        if self.offload is None or not (fragment_size or compression == "png"):
            return self.cut(reply_data(obj, compression), fragment_size, obj.get("id"))
        size = approx_size(obj)
        if size < OFFLOAD_BYTES:
            return self.cut(reply_data(obj, compression), fragment_size, obj.get("id"))
        task = asyncio.ensure_future(self._offloaded_reply(obj, fragment_size, compression))
        return PendingFrames(task, size)

    async def _offloaded_reply(self, obj: dict, fragment_size: int | None,
                               compression: str) -> list[Frame]:
        frag_id = self.ids.next(obj.get("id"))
        assert self.offload is not None
        try:
            return await self.offload(reply_frames, obj, fragment_size, compression, frag_id)
        except Exception:  # the pool broke: the reply is still owed, built here this once
            log.exception("building a big reply in the worker pool failed; built inline")
            return self.cut(reply_data(obj, compression), fragment_size, obj.get("id"))

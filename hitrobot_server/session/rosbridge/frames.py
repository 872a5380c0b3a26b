"""The one frame builder: an op (a published message's ``publish`` op or a reply) as the
frames a rosbridge client gets — JSON or png, whole or cut into ``fragment`` ops.

Frames are ready (a list) or :class:`PendingFrames`: a big op's frames are built in the worker
pool (the :class:`FrameBuilder`'s runner), and the outbox waits for them in place. The pure
builders (:func:`reply_frames` here, ``encoded.publish_frames`` for a message) are also what
the worker runs, so an offloaded op is byte for byte what the inline path sends. A bus
message's encodings, shared by every subscriber, are kept by :mod:`.encoded`.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable

import numpy as np

from ..protocol import png
from ..protocol.bulk import OFFLOAD_BYTES
from ..protocol.errors import MessageId
from ..protocol.fragment import FragmentIds, fragment_bytes, fragment_size_for
from ..types import jsoncodec

log = logging.getLogger(__name__)

Frame = tuple[bytes, bool]  # (payload, is_binary)

Run = Callable[..., Awaitable[list[Frame]]]
"""Runs ``fn(*args)`` away from the event loop (the server's ``WorkerPool.run``,
session/offload.py)."""


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


# ------------------------------------------------------------ pure builders (also the worker's)
def fragments(data: bytes, size: int, frag_id: str) -> list[Frame]:
    """Encoded JSON split into ``fragment`` ops with the id ``frag_id``, in pieces of ``size``
    characters or as many more as the bounds of :func:`~..protocol.fragment.fragment_size_for`
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


# ------------------------------------------------------------ sizes
def approx_size(value: object) -> int:
    """Rough JSON size of a canonical message, without encoding it (an over-estimate is fine:
    it only decides inline or offloaded). Looks into dicts and the first item of a list; one
    call per nested dict, so a LaserScan costs three calls."""
    kind = type(value)
    if kind is dict:
        total = 16 * len(value)
        for item in value.values():
            kind = type(item)
            if kind is dict:
                total += approx_size(item)
            elif kind is list:
                total += _list_size(item)
            elif kind is bytes or kind is np.ndarray or kind is str:
                total += _flat_size(item)
            else:
                total += 12
        return total
    if kind is list:
        return _list_size(value)
    return _flat_size(value)


def _list_size(value: list) -> int:
    if not value:
        return 2
    first = type(value[0])
    each = approx_size(value[0]) if first is dict or first is list else 12
    return each * len(value)


def _flat_size(value: object) -> int:
    kind = type(value)
    if kind is bytes:
        return len(value) * 4 // 3
    if kind is np.ndarray:
        return value.size * (4 if value.itemsize == 1 else 24)
    if kind is str:
        return len(value) + 2
    return 12


# ------------------------------------------------------------ the builder
class FrameBuilder:
    """Builds the frames of every op a server's rosbridge clients get, a published message's
    (through its ``Encoded``) and a reply's alike. One per server: its fragment ids come from
    one counter, so two groups of fragments on one connection never share an id, whether they
    carry topic data (built once, shared by every subscriber) or a reply."""

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

"""Reply ops (service_response, action_result, status, ...) as frames.

A reply that is big (``bulk.OFFLOAD_BYTES`` or more) and fragmented or png-compressed is built
in the worker pool: it is then ``PendingFrames`` (bus/encoded.py), and the outbox keeps it in
order. A bus message's encodings are its own (bus/encoded.py).
"""

from __future__ import annotations

import asyncio
import logging

from ...bus.encoded import Frames, PendingFrames, fragment_ids
from ...protocol import bulk
from ...protocol.bulk import Frame
from ..offload import WorkerPool

log = logging.getLogger(__name__)


def json_frames(
    obj: dict, fragment_size: int | None = None, compression: str = "none"
) -> list[Frame]:
    """Frames for a reply op, fragmented with a fresh id when longer than ``fragment_size``."""
    data = bulk.reply_data(obj, compression)
    if fragment_size and len(data) > fragment_size:
        return bulk.fragments(data, fragment_size, fragment_ids.next(obj.get("id")))
    return [(data, False)]


def reply_frames(
    obj: dict, fragment_size: int | None, compression: str, pool: WorkerPool
) -> Frames:
    """Frames for a reply op; a big one that is fragmented or png-compressed is built in the
    worker pool (pending), so cutting it up never holds the event loop."""
    if not (fragment_size or compression == "png"):
        return json_frames(obj, fragment_size, compression)
    size = bulk.approx_size(obj)
    if size < bulk.OFFLOAD_BYTES:
        return json_frames(obj, fragment_size, compression)
    task = asyncio.ensure_future(_offloaded_reply(obj, fragment_size, compression, pool))
    return PendingFrames(task, size)


async def _offloaded_reply(
    obj: dict, fragment_size: int | None, compression: str, pool: WorkerPool
) -> list[Frame]:
    frag_id = fragment_ids.next(obj.get("id"))
    try:
        return await pool.run(bulk.reply_frames, obj, fragment_size, compression, frag_id)
    except Exception:  # the pool broke: the reply is still owed, built here this once
        log.exception("building a big reply in the worker pool failed; built inline")
        return json_frames(obj, fragment_size, compression)

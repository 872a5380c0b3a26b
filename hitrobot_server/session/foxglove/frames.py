"""Every frame to one Foxglove client goes out here: replies, announcements and statuses never
dropped (within the client's reply budget, as rosbridge's), topic data through its bounded
buffer; and CDR payloads decoded."""

from __future__ import annotations

import logging

from ...bus.cdr import Ros2Codec, codec_for
from ...protocol import foxglove as fg
from ...types.registry import MsgType, TypeRegistry
from ...wire.frames import Frame, Frames
from ..core import ClientCore

log = logging.getLogger(__name__)

LISTED = 5
"""Items of one op named in its one error status (the rest are counted)."""


class FoxgloveOutput:
    """One client's output, in Foxglove's spelling over its client core: the same reply budget
    and error-status limits as a rosbridge client's."""

    def __init__(self, core: ClientCore):
        self.core = core
        self.outbox = core.outbox
        self.node = core.node
        self.reply_limit = core.reply_limit
        self._gathered: dict[str, list[str]] | None = None  # an op's refusals, while batched

    def send(self, obj: dict) -> None:
        """A reply or announcement: never dropped by the send bound."""
        self.core.reply([(fg.dumps(obj), False)])

    def binary(self, data: bytes) -> None:
        self.core.reply([(data, True)])

    def data(self, frames: Frames, topic: str) -> None:
        """Topic data, in the topic's own fair-share stream: when the client's buffer is full,
        the topic over its share loses its oldest messages (the outbox's scheduler)."""
        self.outbox.put(frames, droppable=True, key=topic)

    def status(self, level: int, message: str, status_id: str | None = None) -> None:
        """A status, queued like a reply; error statuses of a client that does not read them
        are limited per second (the rest counted in one line), as a rosbridge client's."""
        if level == fg.ERROR:
            if self.core.skip_error():
                return
            log.info("foxglove client %s: %s", self.node, message)
        self.core.notice(status_frames(level, message, status_id))

    def errors(self, what: str, items: list[str]) -> None:
        """One error status for the items of one op refused for the same reason (``what``),
        naming the first few: an op listing 10,000 unknown ids costs one status, not 10,000."""
        if not items:
            return
        if self._gathered is not None:
            self._gathered.setdefault(what, []).extend(items)
            return
        named = ", ".join(items[:LISTED])
        more = f", … ({len(items)} in all)" if len(items) > LISTED else ""
        self.status(fg.ERROR, f"{what}: {named}{more}")

    def gather(self) -> None:
        """From now on :meth:`errors` collects, until :meth:`flush` (an op run in batches
        still gets one status per reason)."""
        self._gathered = {}

    def flush(self) -> None:
        gathered, self._gathered = self._gathered or {}, None
        for what, items in gathered.items():
            self.errors(what, items)

    @property
    def full(self) -> bool:
        """Whether this client's unread replies are over its budget: a request that would
        queue another reply is refused."""
        return self.core.replies_full()


def status_frames(level: int, message: str, status_id: str | None = None) -> list[Frame]:
    return [(fg.dumps(fg.status(level, message, status_id)), False)]


def decode_cdr(codec: Ros2Codec, payload: bytes, mtype: MsgType) -> dict:
    """A message from CDR; a type without fields (``std_srvs/Trigger`` requests) needs no
    bytes, since writers differ on the padding byte ROS 2 puts in an empty struct."""
    if not mtype.fields:
        return {}
    return codec.decode(payload, mtype)


class CdrError(ValueError):
    """CDR that does not decode as its type (what the worker sends back: short, picklable)."""


def decode_cdr_default(type_name: str, payload: bytes) -> dict:
    """A big message decoded in a worker process, against the built-in types (the server's
    own registry when it is the default one); big numeric arrays come back as numpy arrays."""
    types = TypeRegistry.default()
    try:
        return decode_cdr(codec_for(types), payload, types.msg(type_name))
    except Exception as exc:
        raise CdrError(str(exc)) from None

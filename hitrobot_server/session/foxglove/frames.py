"""Every frame to one Foxglove client goes out here: replies and announcements never dropped,
topic data and statuses through the client's bounded buffer; and CDR payloads decoded."""

from __future__ import annotations

import logging

from ...bus.cdr import Ros2Codec
from ...protocol import foxglove as fg
from ...types.registry import MsgType
from ...wire.frames import Frames
from ..outbox import Outbox

log = logging.getLogger(__name__)


class FoxgloveOutput:
    """One client's output, over its outbox."""

    def __init__(self, outbox: Outbox, node: str):
        self.outbox = outbox
        self.node = node

    def send(self, obj: dict) -> None:
        """A reply or announcement: never dropped by the send bound."""
        self.outbox.put([(fg.dumps(obj), False)])

    def binary(self, data: bytes) -> None:
        self.outbox.put([(data, True)])

    def data(self, frames: Frames, topic: str) -> None:
        """Topic data, in the topic's own fair-share stream: when the client's buffer is full,
        the topic over its share loses its oldest messages (the outbox's scheduler)."""
        self.outbox.put(frames, droppable=True, key=topic)

    def status(self, level: int, message: str, status_id: str | None = None) -> None:
        """A status goes through the bounded buffer like topic data: a client that floods
        junk without reading loses its own oldest reports, and costs at most its bound."""
        if level == fg.ERROR:
            log.info("foxglove client %s: %s", self.node, message)
        self.outbox.put([(fg.dumps(fg.status(level, message, status_id)), False)],
                        droppable=True)


def decode_cdr(codec: Ros2Codec, payload: bytes, mtype: MsgType) -> dict:
    """A message from CDR; a type without fields (``std_srvs/Trigger`` requests) needs no
    bytes, since writers differ on the padding byte ROS 2 puts in an empty struct."""
    if not mtype.fields:
        return {}
    return codec.decode(payload, mtype)

"""The recorder's hand-off from the server's loop to its writer process, as bytes (sans-I/O).

A batch is one byte string: the bytes it counts against the recorder's queue bound, then each
message as a fixed header and its bytes (CDR, the client's JSON, or a pickle of the message).
A topic's name and type cross once, as a ``DEFINE`` entry before its first message; after that
a message names its topic by number. The loop side (:class:`BatchBuilder`) keeps the parts as
they are, to be written with ``writev``: a message costs the loop one ``struct.pack`` and two
appends, where a pickle of the batch cost a tuple per message, a copy of every message's bytes
into the pickle and a 1 MB buffer per batch (page faults in a VM). The writer
(:func:`read_batch`) makes :class:`Item` s of it again.
"""

from __future__ import annotations

import pickle
import struct
from typing import Any, NamedTuple

CDR, JSON, MSG = 0, 1, 2
"""What an :class:`Item`'s ``data`` is: ROS 2 CDR; a client's ``publish`` op as JSON whose
``msg`` is the canonical message as it is (verbatim); the canonical message itself."""
DEFINE = 3
"""An entry that names a topic: its data is ``name`` and ``type`` (utf-8, a newline between)."""
HEAD = struct.Struct("<BBIIqqQ")  # kind, latched, topic number, data bytes, log, publish, seq
BATCH = struct.Struct("<Q")  # the bytes the batch counts against the queue bound


class Item(NamedTuple):
    """One message for the writer (the black box keeps them too)."""

    topic: str
    type_name: str  # pkg/msg/Type
    latched: bool
    log_time: int  # ns
    publish_time: int  # ns
    seq: int
    kind: int  # CDR, JSON or MSG
    data: Any


class BatchBuilder:
    """A batch in the making, on the loop: parts to write and the bytes they count."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.size = 0  # bytes counted against the queue bound

    def define(self, number: int, name: str, type_name: str) -> None:
        data = f"{name}\n{type_name}".encode()
        self.parts += (HEAD.pack(DEFINE, 0, number, len(data), 0, 0, 0), data)

    def add(self, number: int, kind: int, latched: bool, log_time: int, publish_time: int,
            seq: int, data: bytes, size: int) -> None:
        """A message's ``data`` of ``kind`` (CDR, JSON, or MSG pickled), counted as ``size``."""
        self.parts += (HEAD.pack(kind, latched, number, len(data), log_time, publish_time, seq),
                       data)
        self.size += size

    def take(self) -> tuple[list[bytes], int]:
        """The batch's parts (the count first) and the bytes it counts; the builder empties."""
        parts, size = [BATCH.pack(self.size), *self.parts], self.size
        self.parts, self.size = [], 0
        return parts, size


def read_batch(blob: bytes, topics: dict[int, tuple[str, str]]) -> tuple[list[Item], int]:
    """A batch's messages and the bytes it counted; ``topics`` (the topics named so far,
    kept by the reader from batch to batch) learns the batch's ``DEFINE`` entries."""
    view = memoryview(blob)
    (size,) = BATCH.unpack_from(view, 0)
    pos, end, head = BATCH.size, len(view), HEAD.size
    items = []
    while pos < end:
        kind, latched, number, n, log_time, publish_time, seq = HEAD.unpack_from(view, pos)
        pos += head
        data: Any = blob[pos:pos + n]
        pos += n
        if kind == DEFINE:
            name, _, type_name = data.decode().partition("\n")
            topics[number] = (name, type_name)
            continue
        if kind == MSG:
            data = pickle.loads(data)
        name, type_name = topics[number]
        items.append(Item(name, type_name, bool(latched), log_time, publish_time, seq, kind,
                          data))
    return items, size

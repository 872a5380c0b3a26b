"""The on-disk formats of the state store, sans I/O: journal records and the snapshot.

A journal line is ``<crc32 hex> <json>\\n`` where the JSON is one committed batch
``{"seq": n, "set": {key: value | null}}`` (null deletes). Batches are applied in order, so
any prefix of the file is a prefix of the committed changes; a line whose checksum, JSON or
sequence number is wrong ends the readable part. The snapshot is one JSON document with the
sequence number it includes and a SHA-256 of its sections.
"""

from __future__ import annotations

import hashlib
import json
import zlib
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

FORMAT = "hitrobot-server state"
VERSION = 1
MAX_LINE = 16 * 1024 * 1024
"""Longest journal line read back (big values are blobs, so a record is small)."""


class JournalError(ValueError):
    """A file of the store that cannot be used; the text says what is wrong with it."""


def _canonical(value: Any) -> bytes:
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def encode_record(seq: int, changes: dict[str, Any]) -> bytes:
    body = _canonical({"seq": seq, "set": changes})
    return b"%08x %s\n" % (zlib.crc32(body), body)


@dataclass
class JournalRead:
    """What a journal held: the good records in order, and what ended the readable part."""

    records: list[tuple[int, dict[str, Any]]] = field(default_factory=list)
    good_bytes: int = 0  # length of the readable prefix
    problem: str | None = None  # why reading stopped early (None: the whole file was good)
    torn_tail: bool = False  # the problem is only an unfinished last line (a crash mid-write)


def decode_journal(lines: Iterable[bytes], after_seq: int | None,
                   max_line: int = MAX_LINE) -> JournalRead:
    """Parse a journal's lines (bytes: its whole text); records up to ``after_seq`` (already
    in the snapshot) are skipped but must still be well formed. ``after_seq`` None: the
    snapshot was unusable, take them all. A line over ``max_line`` bytes ends the readable
    part (the reader hands it over cut, so it is never held whole)."""
    if isinstance(lines, bytes):
        lines = lines.splitlines(keepends=True)
    read = JournalRead()
    expected: int | None = None
    offset = 0
    for number, line in enumerate(lines, 1):
        if len(line) > max_line:
            read.problem = f"line {number}: longer than {max_line} bytes"
            return read
        complete = line.endswith(b"\n")
        try:
            seq, changes = _decode_line(line)
        except JournalError as exc:
            read.problem = f"line {number}: {exc}"
            read.torn_tail = not complete
            return read
        if expected is not None and seq != expected:
            read.problem = f"line {number}: sequence {seq} where {expected} was due"
            return read
        expected = seq + 1
        offset += len(line)
        read.good_bytes = offset
        if after_seq is None or seq > after_seq:
            read.records.append((seq, changes))
    return read


def _decode_line(line: bytes) -> tuple[int, dict[str, Any]]:
    if not line.endswith(b"\n"):
        raise JournalError("unfinished record")
    head, _, body = line.rstrip(b"\n").partition(b" ")
    try:
        crc = int(head, 16)
    except ValueError:
        raise JournalError("no checksum") from None
    if len(head) != 8 or zlib.crc32(body) != crc:
        raise JournalError("checksum mismatch")
    try:
        doc = json.loads(body)
        seq, changes = doc["seq"], doc["set"]
    except (ValueError, KeyError, TypeError):
        raise JournalError("not a journal record") from None
    if not isinstance(seq, int) or not isinstance(changes, dict):
        raise JournalError("not a journal record")
    return seq, changes


def encode_snapshot(seq: int, sections: dict[str, Any]) -> bytes:
    digest = hashlib.sha256(_canonical({"seq": seq, "sections": sections})).hexdigest()
    doc = {"format": FORMAT, "version": VERSION, "seq": seq, "sha256": digest,
           "sections": sections}
    return json.dumps(doc, indent=1, sort_keys=True, allow_nan=False).encode() + b"\n"


def decode_snapshot(data: bytes) -> tuple[int, dict[str, Any], bool]:
    """``(seq, sections, edited)``; JournalError naming what makes it unusable (not JSON,
    not ours, a newer version). ``edited``: well formed but its checksum does not match (a
    hand edit): its sections are still read, each checked by whoever uses it."""
    try:
        doc = json.loads(data)
    except ValueError as exc:
        raise JournalError(f"not JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise JournalError("not a hitrobot-server state snapshot")
    version = doc.get("version")
    if not isinstance(version, int) or version > VERSION:
        raise JournalError(f"format version {version!r} is newer than ours ({VERSION})")
    seq, sections = doc.get("seq"), doc.get("sections")
    if not isinstance(seq, int) or not isinstance(sections, dict):
        raise JournalError("no 'seq' or 'sections'")
    digest = hashlib.sha256(_canonical({"seq": seq, "sections": sections})).hexdigest()
    return seq, sections, doc.get("sha256") != digest

"""Reading a state folder back at start: the snapshot, then the journal's later records, then
the blobs they name; bad or planted files set aside (never deleted, never followed), and every
read bounded before it starts."""

from __future__ import annotations

import hashlib
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .files import (
    aside_folder,
    copy_tail,
    is_link,
    is_plain_file,
    lines,
    read_bounded,
    set_aside,
    stamp,
    write_aside,
)
from .journal import MAX_LINE, JournalError, decode_journal, decode_snapshot

log = logging.getLogger(__name__)

SNAPSHOT = "snapshot.json"
JOURNAL = "journal.log"
BLOBS = "blobs"
BLOB_REF = "$blob"
MAX_SNAPSHOT = 64 * 1024 * 1024
"""Largest snapshot read (it references blobs, so it stays small)."""
MAX_BLOB = 128 * 1024 * 1024
"""Largest blob read back (a map or masks); a bigger one is refused before it is read."""


@dataclass
class Restored:
    """What start-up found, for the log, the diagnostics and the console."""

    path: Path
    sections: dict[str, Any] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)  # what could not be read, and where it went
    fresh: bool = True  # nothing was restored (empty folder or --fresh)
    summary: str = ""  # what the robot and nodes took back, set by whoever assembles them


def _skip(path: Path, restored: Restored, name: str, why: str, stamp: str) -> None:
    where = set_aside(path, name, stamp)
    text = f"{name}: {why}; moved to {where}"
    log.warning("state: %s", text)
    restored.skipped.append(text)


def set_aside_links(path: Path, restored: Restored) -> None:
    """A link planted where a file or folder of the store belongs is moved aside unread."""
    for name in (SNAPSHOT, JOURNAL, BLOBS):
        if is_link(path / name):
            _skip(path, restored, name, "a symbolic link, not a file of the store (not followed)",
                  "link")
        elif name != BLOBS and (path / name).exists() and not is_plain_file(path / name):
            _skip(path, restored, name, "not a regular file", "odd")
    if (path / BLOBS).exists() and not (path / BLOBS).is_dir():
        _skip(path, restored, BLOBS, "not a folder", "odd")


def load(path: Path, restored: Restored) -> tuple[int, dict[str, Any]]:
    """Snapshot, then the journal's later records; bad files set aside, never deleted."""
    sections: dict[str, Any] = {}
    seq: int | None = 0
    snapshot = path / SNAPSHOT
    if snapshot.exists():
        try:
            data = read_bounded(snapshot, MAX_SNAPSHOT)
            seq, sections, edited = decode_snapshot(data)
        except (JournalError, ValueError) as exc:
            _skip(path, restored, SNAPSHOT, str(exc), "bad")
            seq = None  # the journal's records are all we have
        else:
            if edited:
                where = write_aside(path, SNAPSHOT + ".edited", data)
                text = (f"{SNAPSHOT}: checksum mismatch (edited by hand?): its sections are "
                        f"read and checked one by one; the file as found is kept at {where}")
                log.warning("state: %s", text)
                restored.skipped.append(text)
            del data
    last = _replay_journal(path, restored, seq, sections)
    values: dict[str, Any] = {}
    for key, value in sections.items():
        try:
            values[key] = resolve(path, value)
        except JournalError as exc:
            text = f"section {key!r} skipped: {exc}"
            log.warning("state: %s", text)
            restored.skipped.append(text)
    return last, values


def _replay_journal(path: Path, restored: Restored, seq: int | None,
                    sections: dict[str, Any]) -> int:
    journal = path / JOURNAL
    last = seq or 0
    if not journal.exists():
        return last
    read = decode_journal(lines(journal, MAX_LINE), seq)
    for record_seq, changes in read.records:
        for key, value in changes.items():
            if value is None:
                sections.pop(key, None)
            else:
                sections[key] = value
        last = max(last, record_seq)
    if read.problem is not None:
        kind = "an unfinished last record (a crash while writing)" if read.torn_tail \
            else "a damaged record"
        if journal.stat().st_size - read.good_bytes <= MAX_LINE:
            where = aside_folder(path) / f"{JOURNAL}.tail.{stamp()}"
            copy_tail(journal, read.good_bytes, where)
            rest = "the rest moved to"
        else:  # a huge tail is not copied: the file itself is moved, as found
            where = set_aside(path, JOURNAL, "damaged")
            rest = "the file as found moved to"
        text = (f"{JOURNAL}: {kind} at {read.problem}; kept the {len(read.records)} good "
                f"records before it, {rest} {where}")
        (log.info if read.torn_tail else log.warning)("state: %s", text)
        restored.skipped.append(text)
    return last


def resolve(path: Path, value: Any) -> Any:
    """A stored value with its blob read back and checked (its size before reading it)."""
    if not (isinstance(value, dict) and BLOB_REF in value):
        return value
    digest = value[BLOB_REF]
    if not isinstance(digest, str) or len(digest) != 64 or not digest.isalnum():
        raise JournalError("a bad blob reference")
    name = f"{BLOBS}/{digest}"
    blob = path / name
    if is_link(blob):
        where = set_aside(path, name, "link")
        raise JournalError(f"its blob is a symbolic link (not followed; moved to {where})")
    try:
        data = read_bounded(blob, MAX_BLOB)
    except ValueError as exc:
        where = set_aside(path, name, "too-large")
        raise JournalError(f"its blob is too large ({exc}); moved unread to {where}") from None
    except OSError as exc:
        raise JournalError(f"its blob is missing ({exc.strerror})") from None
    if hashlib.sha256(data).hexdigest() != digest:
        del data
        where = set_aside(path, name, "bad")
        raise JournalError(f"its blob is damaged (moved to {where})")
    return data


def private_blobs(path: Path) -> None:
    """Blob files made private (0600) where an older version left them readable."""
    folder = path / BLOBS
    for entry in os.scandir(folder):
        if entry.is_file(follow_symlinks=False) and entry.stat(follow_symlinks=False).st_mode \
                & 0o077:
            os.chmod(entry.path, 0o600, follow_symlinks=False)

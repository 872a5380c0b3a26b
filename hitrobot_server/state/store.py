"""One robot's working state on disk: a snapshot, an append-only journal and content blobs.

Why this design (figures in ``bench/bench_state.py``): a change is one checksummed journal
line appended and fsynced, whatever else the state holds, so a POI edit next to a 20 MB map
costs an append, not a rewrite of the map. Large values (maps, masks) are ``bytes`` and go to
content-addressed blob files, written (and fsynced) once per new content before the journal
line that names them. When the journal grows past ``compact_bytes`` the state is written as a
new snapshot (temporary file, fsync, rename, fsync the folder) and the journal starts over.

All disk work runs in a worker thread, one batch at a time; changes made while a batch is being
written are coalesced (latest value per key) into the next one, which is committed as one
journal line: after a crash the state is a prefix of the batches, so a prefix of the changes.
:meth:`StateStore.put` returns a future resolved once its change is durable: acknowledge a
request only after it.

Bad files never stop the robot and are never deleted: a file that cannot be read is moved to
``set-aside/`` with a time stamp, what was skipped is logged and kept in :attr:`status`.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import logging
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .journal import JournalError, decode_journal, decode_snapshot, encode_record, encode_snapshot

log = logging.getLogger(__name__)

SNAPSHOT = "snapshot.json"
JOURNAL = "journal.log"
BLOBS = "blobs"
ASIDE = "set-aside"
COMPACT_BYTES = 4 * 1024 * 1024
"""Journal size that triggers a snapshot (a snapshot is small: blobs are referenced)."""
BLOB_REF = "$blob"


@dataclass
class Restored:
    """What start-up found, for the log, the diagnostics and the console."""

    path: Path
    sections: dict[str, Any] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)  # what could not be read, and where it went
    fresh: bool = True  # nothing was restored (empty folder or --fresh)
    summary: str = ""  # what the robot and nodes took back, set by whoever assembles them


class StateStore:
    """The state folder of one robot identity. Create with :meth:`open` (blocking: call it in
    a thread at start-up), then :meth:`put` changes from the event loop."""

    def __init__(self, directory: Path, restored: Restored, seq: int,
                 compact_bytes: int = COMPACT_BYTES) -> None:
        self.path = Path(directory)
        self.restored = restored
        self.compact_bytes = compact_bytes
        self._values: dict[str, Any] = dict(restored.sections)  # what the nodes see
        self._durable: dict[str, Any] = {}  # stored form (blob refs); writer thread only
        self._seq = seq
        self._pending: dict[str, Any] = {}
        self._waiters: list[asyncio.Future] = []
        self._wake: asyncio.Event | None = None
        self._writer: asyncio.Task | None = None
        self._journal_size = 0
        self.writes = 0
        self.last_write: float | None = None  # wall-clock time of the last durable batch
        self.errors: list[str] = list(restored.skipped)

    # ------------------------------------------------------------------ opening
    @classmethod
    def open(cls, directory: Path, fresh: bool = False,
             compact_bytes: int = COMPACT_BYTES) -> StateStore:
        """Read the folder (creating it), set bad files aside, and write a clean snapshot of
        what was read so the next start reads one file. ``fresh``: whatever is there is set
        aside, not read."""
        path = Path(directory)
        path.mkdir(parents=True, exist_ok=True)
        restored = Restored(path)
        seq = 0
        if fresh:
            for name in (SNAPSHOT, JOURNAL):
                if (path / name).exists():
                    where = _set_aside(path, name, "fresh")
                    log.info("state: --fresh: %s moved to %s", name, where)
            values: dict[str, Any] = {}
        else:
            seq, values = _load(path, restored)
            restored.sections = values
            restored.fresh = not values
        store = cls(path, restored, seq, compact_bytes)
        store._durable = {k: store._stored_form(v) for k, v in values.items()}
        store._write_snapshot()
        return store

    # ------------------------------------------------------------------ reading
    def get(self, key: str, default: Any = None) -> Any:
        return self._values.get(key, default)

    def keys(self, prefix: str = "") -> list[str]:
        return [k for k in self._values if k.startswith(prefix)]

    # ------------------------------------------------------------------ writing
    def put(self, key: str, value: Any) -> asyncio.Future:
        """Record a change (``None`` deletes the key); the future resolves when it is on disk
        (or fails with the OSError that kept it off). JSON values or ``bytes``."""
        loop = asyncio.get_running_loop()
        if self._wake is None:
            self._wake = asyncio.Event()
            self._writer = loop.create_task(self._write_loop(), name="state-writer")
        if value is None:
            self._values.pop(key, None)
        else:
            self._values[key] = value
        self._pending[key] = value
        future = loop.create_future()
        self._waiters.append(future)
        self._wake.set()
        return future

    async def flush(self) -> None:
        """Wait until everything put so far is on disk (errors are in :attr:`errors`)."""
        if self._waiters:
            await asyncio.gather(*self._waiters, return_exceptions=True)

    async def close(self) -> None:
        await self.flush()
        if self._writer is not None:
            self._writer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._writer
            self._writer = None

    def reject(self, key: str, reason: str) -> None:
        """A consumer could not use a restored section: log it and keep a copy of the value
        aside (it is overwritten by the next change to that key)."""
        value = self.restored.sections.get(key)
        text = f"section {key!r} skipped: {reason}"
        if value is not None:
            data = value if isinstance(value, bytes) else repr(value).encode()
            where = _write_aside(self.path, f"{key.replace('/', '.')}.rejected", data)
            text += f" (its value kept at {where})"
        log.warning("state: %s", text)
        self.errors.append(text)
        self.restored.skipped.append(text)

    def keep_copy(self, why: str) -> Path:
        """Copy the snapshot as it is into ``set-aside/`` before newer state replaces it
        (values in blobs are referenced, not copied)."""
        return _write_aside(self.path, f"{SNAPSHOT}.{why}", (self.path / SNAPSHOT).read_bytes())

    def status(self) -> dict[str, Any]:
        return {"path": str(self.path), "writes": self.writes, "last_write": self.last_write,
                "errors": list(self.errors[-5:]), "keys": len(self._values)}

    async def _write_loop(self) -> None:
        assert self._wake is not None
        while True:
            await self._wake.wait()
            self._wake.clear()
            batch, waiters = self._pending, self._waiters
            self._pending, self._waiters = {}, []
            try:
                await asyncio.to_thread(self._write_batch, batch)
            except (OSError, ValueError, TypeError) as exc:  # disk, or a value not JSON
                text = f"write failed: {exc}"
                log.error("state %s: %s", self.path, text)
                self.errors.append(text)
                if isinstance(exc, OSError):  # tried again with the next change
                    self._pending = {**batch, **self._pending}
                failure = exc if isinstance(exc, OSError) else OSError(str(exc))
                for future in waiters:
                    if not future.done():
                        future.set_exception(failure)
                continue
            self.writes += 1
            self.last_write = time.time()
            for future in waiters:
                if not future.done():
                    future.set_result(None)

    # ------------------------------------------------------------------ the writer thread
    def _stored_form(self, value: Any) -> Any:
        """JSON for the journal: bytes become a reference to their blob (written first)."""
        if isinstance(value, bytes | bytearray | memoryview):
            data = bytes(value)
            digest = hashlib.sha256(data).hexdigest()
            blob = self.path / BLOBS / digest
            if not blob.exists():
                _atomic_write(blob, data)
            return {BLOB_REF: digest, "size": len(data)}
        return value

    def _write_batch(self, batch: dict[str, Any]) -> None:
        changes = {key: self._stored_form(value) for key, value in batch.items()}
        record = encode_record(self._seq + 1, changes)
        with open(self.path / JOURNAL, "ab") as f:
            try:
                f.write(record)
                f.flush()
                os.fsync(f.fileno())
            except OSError:  # no half line may stay in front of the next batch's
                with contextlib.suppress(OSError):
                    f.truncate(self._journal_size)
                raise
        self._seq += 1
        self._journal_size += len(record)
        for key, value in changes.items():
            if value is None:
                self._durable.pop(key, None)
            else:
                self._durable[key] = value
        if self._journal_size > self.compact_bytes:
            self._write_snapshot()

    def _write_snapshot(self) -> None:
        """The durable state as the new snapshot, then an empty journal (a crash between the
        two leaves journal records the snapshot already has: they are skipped by ``seq``)."""
        _atomic_write(self.path / SNAPSHOT, encode_snapshot(self._seq, self._durable))
        _atomic_write(self.path / JOURNAL, b"")
        self._journal_size = 0
        self._collect_blobs()

    def _collect_blobs(self) -> None:
        """Blobs no longer referenced are old versions of a value, not bad files: removed."""
        live = {v[BLOB_REF] for v in self._durable.values()
                if isinstance(v, dict) and BLOB_REF in v}
        folder = self.path / BLOBS
        if folder.is_dir():
            for blob in folder.iterdir():
                if blob.name not in live and not blob.name.startswith("."):
                    blob.unlink(missing_ok=True)


# ---------------------------------------------------------------------- loading
def _load(path: Path, restored: Restored) -> tuple[int, dict[str, Any]]:
    """Snapshot, then the journal's later records; bad files set aside, never deleted."""

    def skip(name: str, why: str, stamp: str) -> None:
        where = _set_aside(path, name, stamp)
        text = f"{name}: {why}; moved to {where}"
        log.warning("state: %s", text)
        restored.skipped.append(text)

    sections: dict[str, Any] = {}
    seq: int | None = 0
    snapshot = path / SNAPSHOT
    if snapshot.exists():
        try:
            seq, sections, edited = decode_snapshot(snapshot.read_bytes())
        except JournalError as exc:
            skip(SNAPSHOT, str(exc), "bad")
            seq = None  # the journal's records are all we have
        else:
            if edited:
                where = _write_aside(path, SNAPSHOT + ".edited", snapshot.read_bytes())
                text = (f"{SNAPSHOT}: checksum mismatch (edited by hand?): its sections are "
                        f"read and checked one by one; the file as found is kept at {where}")
                log.warning("state: %s", text)
                restored.skipped.append(text)
    journal = path / JOURNAL
    last = seq or 0
    if journal.exists():
        data = journal.read_bytes()
        read = decode_journal(data, seq)
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
            where = _write_aside(path, JOURNAL + ".tail", data[read.good_bytes:])
            text = (f"{JOURNAL}: {kind} at {read.problem}; kept the {len(read.records)} good "
                    f"records before it, the rest moved to {where}")
            (log.info if read.torn_tail else log.warning)("state: %s", text)
            restored.skipped.append(text)
    values: dict[str, Any] = {}
    for key, value in sections.items():
        try:
            values[key] = _resolve(path, value)
        except JournalError as exc:
            text = f"section {key!r} skipped: {exc}"
            log.warning("state: %s", text)
            restored.skipped.append(text)
    return last, values


def _resolve(path: Path, value: Any) -> Any:
    """A stored value with its blob read back and checked."""
    if not (isinstance(value, dict) and BLOB_REF in value):
        return value
    digest = value[BLOB_REF]
    if not isinstance(digest, str) or len(digest) != 64 or not digest.isalnum():
        raise JournalError("a bad blob reference")
    blob = path / BLOBS / digest
    try:
        data = blob.read_bytes()
    except OSError as exc:
        raise JournalError(f"its blob is missing ({exc.strerror})") from None
    if hashlib.sha256(data).hexdigest() != digest:
        where = _set_aside(path, f"{BLOBS}/{digest}", "bad")
        raise JournalError(f"its blob is damaged (moved to {where})")
    return data


# ---------------------------------------------------------------------- files
def _stamp() -> str:
    return time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + f"-{time.time_ns() % 10**9:09d}"


def _set_aside(path: Path, name: str, why: str) -> Path:
    """Move ``path/name`` into ``set-aside/`` under a new name (never overwriting)."""
    aside = path / ASIDE
    aside.mkdir(exist_ok=True)
    target = aside / f"{name.replace('/', '.')}.{why}.{_stamp()}"
    os.replace(path / name, target)
    _fsync_dir(aside)
    _fsync_dir(path)
    return target


def _write_aside(path: Path, name: str, data: bytes) -> Path:
    target = path / ASIDE / f"{name}.{_stamp()}"
    _atomic_write(target, data)
    return target


def _atomic_write(target: Path, data: bytes) -> None:
    """Temporary file, fsync, rename over the target, fsync the folder."""
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = target.with_name(f".{target.name}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, target)
    _fsync_dir(target.parent)


def _fsync_dir(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)

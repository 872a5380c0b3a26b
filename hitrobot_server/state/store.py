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
request only after it. A batch that cannot be written (disk full) fails every put in it with a
:class:`StateWriteError` and is dropped: what :meth:`get` answers goes back to what is on disk,
so the requester answers with an error and takes its change back; :attr:`write_error` says why
until a write succeeds again.

Bad files never stop the robot and are never deleted: a file that cannot be read is moved to
``set-aside/`` with a time stamp, what was skipped is logged and kept in :attr:`status`. The
folder's own safety (links, modes, bounds, the lock) is :mod:`.files`.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import hashlib
import logging
import os
import time
from pathlib import Path
from typing import Any

from .files import (
    FolderLock,
    StateFolderError,
    atomic_write,
    is_link,
    make_folder,
    open_append,
    read_bounded,
    reason,
    set_aside,
    write_aside,
)
from .journal import encode_record, encode_snapshot
from .loading import (
    BLOB_REF,
    BLOBS,
    JOURNAL,
    MAX_SNAPSHOT,
    SNAPSHOT,
    Restored,
    load,
    private_blobs,
    set_aside_links,
)

log = logging.getLogger(__name__)

COMPACT_BYTES = 4 * 1024 * 1024
"""Journal size that triggers a snapshot (a snapshot is small: blobs are referenced)."""
UNUSABLE = (errno.EROFS, errno.EACCES, errno.EPERM)

__all__ = ["JOURNAL", "SNAPSHOT", "Restored", "StateStore", "StateWriteError"]


class StateWriteError(OSError):
    """A change that did not reach the disk (and was taken back); the text says why."""


class StateStore:
    """The state folder of one robot identity. Create with :meth:`open` (blocking: call it in
    a thread at start-up), then :meth:`put` changes from the event loop."""

    def __init__(self, directory: Path, restored: Restored, seq: int,
                 compact_bytes: int = COMPACT_BYTES, lock: FolderLock | None = None) -> None:
        self.path = Path(directory)
        self.restored = restored
        self.compact_bytes = compact_bytes
        self._lock = lock
        self._values: dict[str, Any] = dict(restored.sections)  # what the nodes see
        self._committed: dict[str, Any] = dict(restored.sections)  # what is on disk
        self._durable: dict[str, Any] = {}  # stored form (blob refs); writer thread only
        self._seq = seq
        self._pending: dict[str, Any] = {}
        self._waiters: list[asyncio.Future] = []
        self._in_flight: list[asyncio.Future] = []
        self._wake: asyncio.Event | None = None
        self._writer: asyncio.Task | None = None
        self._journal_size = 0
        self._journal_suspect = False  # a failed append may have left bytes: rewrite whole
        self.writes = 0
        self.write_failures = 0
        self.last_write: float | None = None  # wall-clock time of the last durable batch
        self.write_error: str | None = None
        """Why the last write failed (``disk full``), until a write succeeds again: while it
        is set, changes are refused. Read by the diagnostics, the console and /healthz."""
        self.errors: list[str] = list(restored.skipped)

    @property
    def healthy(self) -> bool:
        """The last write reached the disk (or none failed yet)."""
        return self.write_error is None

    # ------------------------------------------------------------------ opening
    @classmethod
    def open(cls, directory: Path, fresh: bool = False,
             compact_bytes: int = COMPACT_BYTES) -> StateStore:
        """Lock the folder (creating it), read it, set bad or planted files aside, and write a
        clean snapshot of what was read so the next start reads one file. ``fresh``: whatever
        is there is set aside, not read. StateFolderError (with the reason and what to do)
        when the folder cannot be used: another server holds it, or it cannot be written."""
        path = Path(directory)
        try:
            path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
            make_folder(path)
            lock = FolderLock(path)
        except StateFolderError as exc:
            log.error("state: %s", exc)
            raise
        except OSError as exc:
            if exc.errno not in UNUSABLE:
                raise
            raise _unusable(path, exc) from None
        try:
            store = cls._read(path, fresh, compact_bytes, lock)
        except BaseException:
            lock.release()
            raise
        return store

    @classmethod
    def _read(cls, path: Path, fresh: bool, compact_bytes: int, lock: FolderLock) -> StateStore:
        restored = Restored(path)
        seq = 0
        set_aside_links(path, restored)
        make_folder(path / BLOBS)
        private_blobs(path)
        if fresh:
            for name in (SNAPSHOT, JOURNAL):
                if (path / name).exists():
                    where = set_aside(path, name, "fresh")
                    log.info("state: --fresh: %s moved to %s", name, where)
            values: dict[str, Any] = {}
        else:
            seq, values = load(path, restored)
            restored.sections = values
            restored.fresh = not values
        store = cls(path, restored, seq, compact_bytes, lock)
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
        """Record a change (``None`` deletes the key); the future resolves when it is on disk,
        or fails with :class:`StateWriteError` when it could not be written (the change is
        then taken back: :meth:`get` answers what is on disk). JSON values or ``bytes``."""
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
        """Wait until everything put so far is written or refused (errors in :attr:`errors`)."""
        waiting = [*self._in_flight, *self._waiters]
        if waiting:
            await asyncio.gather(*waiting, return_exceptions=True)

    async def close(self) -> None:
        await self.flush()
        if self._writer is not None:
            self._writer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._writer
            self._writer = None
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    def reject(self, key: str, reason: str) -> None:
        """A consumer could not use a restored section: log it and keep a copy of the value
        aside (it is overwritten by the next change to that key)."""
        value = self.restored.sections.get(key)
        text = f"section {key!r} skipped: {reason}"
        if value is not None:
            data = value if isinstance(value, bytes) else repr(value).encode()
            where = write_aside(self.path, f"{key.replace('/', '.')}.rejected", data)
            text += f" (its value kept at {where})"
        log.warning("state: %s", text)
        self.errors.append(text)
        self.restored.skipped.append(text)

    def keep_copy(self, why: str) -> Path:
        """Copy the snapshot as it is into ``set-aside/`` before newer state replaces it
        (values in blobs are referenced, not copied)."""
        return write_aside(self.path, f"{SNAPSHOT}.{why}",
                           read_bounded(self.path / SNAPSHOT, MAX_SNAPSHOT))

    def status(self) -> dict[str, Any]:
        return {"path": str(self.path), "writes": self.writes, "last_write": self.last_write,
                "errors": list(self.errors[-5:]), "keys": len(self._values),
                "write_error": self.write_error, "write_failures": self.write_failures}

    async def _write_loop(self) -> None:
        assert self._wake is not None
        while True:
            await self._wake.wait()
            self._wake.clear()
            batch, waiters = self._pending, self._waiters
            self._pending, self._waiters, self._in_flight = {}, [], waiters
            try:
                await asyncio.to_thread(self._write_batch, batch)
            except (OSError, ValueError, TypeError) as exc:  # disk, or a value not JSON
                self._failed(batch, waiters, exc)
                continue
            finally:
                self._in_flight = []
            self.writes += 1
            self.last_write = time.time()
            if self.write_error is not None:
                log.warning("state %s: saving again (%s is over)", self.path, self.write_error)
            self.write_error = None
            _apply(self._committed, batch)
            for future in waiters:
                if not future.done():
                    future.set_result(None)

    def _failed(self, batch: dict[str, Any], waiters: list[asyncio.Future],
                exc: Exception) -> None:
        """A batch that did not reach the disk: refused, and taken back from what nodes see
        (a key put again since keeps its newer value, which the next batch tries)."""
        why = reason(exc) if isinstance(exc, OSError) else f"not storable ({exc})"
        text = f"write failed: {why}"
        self.write_failures += 1
        if why == self.write_error:  # still failing: said once, counted in write_failures
            log.debug("state %s: %s (%s)", self.path, text, exc)
        else:
            log.error("state %s: %s (%s)", self.path, text, exc)
            self.errors.append(text)
        if isinstance(exc, OSError):
            self.write_error = why
        for key in batch:
            if key in self._pending:
                continue
            if key in self._committed:
                self._values[key] = self._committed[key]
            else:
                self._values.pop(key, None)
        failure = StateWriteError(f"not saved to the state folder: {why}")
        for future in waiters:
            if not future.done():
                future.set_exception(failure)

    # ------------------------------------------------------------------ the writer thread
    def _stored_form(self, value: Any) -> Any:
        """JSON for the journal: bytes become a reference to their blob (written first)."""
        if isinstance(value, bytes | bytearray | memoryview):
            data = bytes(value)
            digest = hashlib.sha256(data).hexdigest()
            blob = self.path / BLOBS / digest
            if not blob.exists() or is_link(blob):
                atomic_write(blob, data)
            return {BLOB_REF: digest, "size": len(data)}
        return value

    def _write_batch(self, batch: dict[str, Any]) -> None:
        changes = {key: self._stored_form(value) for key, value in batch.items()}
        if self._journal_suspect:  # a failed append may have left bytes: a whole snapshot
            durable = dict(self._durable)
            _apply(durable, changes)
            atomic_write(self.path / SNAPSHOT, encode_snapshot(self._seq + 1, durable))
            self._seq += 1
            self._durable = durable
            self._compact()
            return
        record = encode_record(self._seq + 1, changes)
        fd = open_append(self.path / JOURNAL)
        try:
            done = 0
            while done < len(record):  # a nearly full disk takes part of a write
                done += os.write(fd, record[done:])
            os.fsync(fd)
        except OSError:  # no half line may stay in front of the next batch's
            try:
                os.ftruncate(fd, self._journal_size)
            except OSError:
                self._journal_suspect = True
            raise
        finally:
            os.close(fd)
        self._seq += 1
        self._journal_size += len(record)
        _apply(self._durable, changes)
        if self._journal_size > self.compact_bytes:
            self._compact()

    def _compact(self) -> None:
        """A snapshot after a committed batch: its failure loses nothing (the journal holds
        the batch), so it is logged and tried again later."""
        try:
            self._write_snapshot()
        except OSError as exc:
            log.warning("state %s: compaction failed (%s); tried again with the next change",
                        self.path, reason(exc))
            self._journal_suspect = True
        else:
            self._journal_suspect = False

    def _write_snapshot(self) -> None:
        """The durable state as the new snapshot, then an empty journal (a crash between the
        two leaves journal records the snapshot already has: they are skipped by ``seq``)."""
        atomic_write(self.path / SNAPSHOT, encode_snapshot(self._seq, self._durable))
        atomic_write(self.path / JOURNAL, b"")
        self._journal_size = 0
        self._collect_blobs()

    def _collect_blobs(self) -> None:
        """Blobs no longer referenced are old versions of a value, not bad files: removed
        (only plain files of the store's own blobs folder; a link is never followed)."""
        live = {v[BLOB_REF] for v in self._durable.values()
                if isinstance(v, dict) and BLOB_REF in v}
        for entry in os.scandir(self.path / BLOBS):
            if entry.name not in live and not entry.name.startswith(".") \
                    and entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)


def _apply(stored: dict[str, Any], changes: dict[str, Any]) -> None:
    for key, value in changes.items():
        if value is None:
            stored.pop(key, None)
        else:
            stored[key] = value


def _unusable(path: Path, exc: OSError) -> StateFolderError:
    text = (f"state folder {path} cannot be used: {reason(exc)} ({exc.strerror}). The server "
            "does not run without saving its state (it would acknowledge changes it then "
            "loses): make the folder writable, or give another --state-dir")
    log.error("state: %s", text)
    return StateFolderError(text)

"""The state folder's file operations, safe against what a careless script or a local user
plants in it: nothing is opened through a symbolic link (``O_NOFOLLOW``; a planted link is
moved aside, never followed), nothing is written or removed outside the folder, files are
0600 and folders 0700, reads are bounded before they start, and one server holds the folder
(an exclusive ``flock`` on ``lock``, naming its pid)."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import stat
import time
from collections.abc import Iterator
from pathlib import Path

ASIDE = "set-aside"
LOCK = "lock"
FILE_MODE = 0o600
DIR_MODE = 0o700
_READ = os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC
_CHUNK = 1 << 20

REASONS = {
    errno.ENOSPC: "disk full",
    errno.EDQUOT: "disk quota exceeded",
    errno.EROFS: "read-only file system",
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
    errno.EFBIG: "file size limit reached",
    errno.EIO: "input/output error",
    errno.ELOOP: "a symbolic link where a file of the store belongs",
}


class StateFolderError(OSError):
    """The state folder cannot be used at all (locked by another server, read-only, not a
    folder); the text says why and what to do."""


def reason(exc: OSError) -> str:
    """A short cause for the operator: ``disk full`` rather than ``[Errno 28] …``."""
    return REASONS.get(exc.errno or 0, exc.strerror or str(exc))


def is_link(path: Path) -> bool:
    try:
        return stat.S_ISLNK(os.lstat(path).st_mode)
    except FileNotFoundError:
        return False


def is_plain_file(path: Path) -> bool:
    """A regular file, not a link (``lstat``: the link itself is looked at)."""
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except FileNotFoundError:
        return False


def make_folder(path: Path) -> None:
    """Create ``path`` (0700) if missing; a link or a non-folder there is refused."""
    try:
        os.mkdir(path, DIR_MODE)
    except FileExistsError:
        mode = os.lstat(path).st_mode
        if not stat.S_ISDIR(mode):
            raise StateFolderError(f"{path} is not a folder (a link or a file is there)") from None
        if stat.S_IMODE(mode) & 0o077:
            os.chmod(path, DIR_MODE, follow_symlinks=False)


def read_bounded(path: Path, limit: int) -> bytes:
    """The whole file, refused (ValueError) before reading when it is over ``limit`` bytes;
    OSError (ELOOP) when it is a link."""
    fd = os.open(path, _READ)
    with os.fdopen(fd, "rb") as f:
        size = os.fstat(fd).st_size
        if size > limit:
            raise ValueError(f"{size} bytes, over the {limit}-byte limit")
        return f.read(limit + 1)[:limit]


def lines(path: Path, limit: int) -> Iterator[bytes]:
    """The file's lines, each at most ``limit + 1`` bytes (a longer one is cut there: the
    reader sees a line without its newline); never a whole file in memory."""
    fd = os.open(path, _READ)
    with os.fdopen(fd, "rb") as f:
        while line := f.readline(limit + 1):
            yield line


def copy_tail(source: Path, offset: int, target: Path) -> None:
    """Bytes ``offset``.. of ``source`` into a new private file ``target``, chunk by chunk."""
    fd = os.open(source, _READ)
    with os.fdopen(fd, "rb") as f:
        f.seek(offset)
        with _new_file(target) as out:
            while chunk := f.read(_CHUNK):
                out.write(chunk)
            out.flush()
            os.fsync(out.fileno())
    fsync_dir(target.parent)


def open_append(path: Path) -> int:
    """The journal for appending (created 0600); ELOOP if a link was planted there."""
    return os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC,
                   FILE_MODE)


def _new_file(target: Path):
    with contextlib.suppress(FileNotFoundError):
        os.unlink(target)  # a leftover (or planted link) of this name: the link, not its target
    fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC,
                 FILE_MODE)
    return os.fdopen(fd, "wb")


def atomic_write(target: Path, data: bytes) -> None:
    """Temporary file (0600, never through a link), fsync, rename over the target, fsync the
    folder. The folder itself must already be a checked folder of the store."""
    tmp = target.with_name(f".{target.name}.tmp")
    try:
        with _new_file(tmp) as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
    except OSError:  # a full disk: the partial copy must not keep the space
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    os.replace(tmp, target)
    fsync_dir(target.parent)


def fsync_dir(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def stamp() -> str:
    return time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + f"-{time.time_ns() % 10**9:09d}"


def aside_folder(path: Path) -> Path:
    """``path/set-aside`` as a real folder: a link planted under that name is itself moved
    out of the way (renamed in place, never followed)."""
    aside = path / ASIDE
    if is_link(aside) or (aside.exists() and not aside.is_dir()):
        os.replace(aside, path / f"{ASIDE}.not-a-folder.{stamp()}")
    make_folder(aside)
    return aside


def set_aside(path: Path, name: str, why: str) -> Path:
    """Move ``path/name`` (a file, or a link as a link) into ``set-aside/`` under a new name."""
    aside = aside_folder(path)
    target = aside / f"{name.replace('/', '.')}.{why}.{stamp()}"
    os.replace(path / name, target)
    fsync_dir(aside)
    fsync_dir(path)
    return target


def write_aside(path: Path, name: str, data: bytes) -> Path:
    target = aside_folder(path) / f"{name}.{stamp()}"
    atomic_write(target, data)
    return target


class FolderLock:
    """An exclusive ``flock`` on ``path/lock`` for as long as the server uses the folder; the
    file holds the holder's pid so a second server can name it."""

    def __init__(self, path: Path) -> None:
        lock = path / LOCK
        if is_link(lock):
            set_aside(path, LOCK, "link")
        self.fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, FILE_MODE)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(self.fd, 32, 0).decode(errors="replace").strip() or "unknown"
            os.close(self.fd)
            raise StateFolderError(
                f"state folder {path} is in use by another server (pid {holder}); stop it, or "
                "give this one another --state-dir") from None
        os.ftruncate(self.fd, 0)
        os.pwrite(self.fd, f"{os.getpid()}\n".encode(), 0)

    def release(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)  # closing the descriptor releases the flock
            self.fd = -1

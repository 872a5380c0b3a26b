"""The recordings on disk: files opened only where they are named (never through a symlink), a
file that is cut back to its last whole write when the disk fails, the parts of a split
recording, and the disk budget that removes the oldest recordings first."""

from __future__ import annotations

import contextlib
import logging
import os
import stat
from collections import deque
from pathlib import Path

log = logging.getLogger(__name__)

MIN_FREE = 1024 * 1024  # a recording is not started in a folder with less room than this
_NO_FOLLOW = os.O_NOFOLLOW | os.O_CLOEXEC | os.O_NONBLOCK  # NONBLOCK: a planted FIFO never hangs


def split_name(path: Path, index: int) -> Path:
    """The ``index``-th file of a split recording: ``run.mcap``, ``run_1.mcap``, ..."""
    return path if index == 0 else path.with_name(f"{path.stem}_{index}{path.suffix}")


def open_file(path: Path, *, create: bool = True, exclusive: bool = True) -> int:
    """A file descriptor to write ``path``: opened directly in its folder, never through a
    symlink (O_NOFOLLOW), a regular file only; ``exclusive``: a new file (O_EXCL), else an
    existing one is emptied. OSError says why not."""
    flags = os.O_WRONLY | _NO_FOLLOW | (os.O_CREAT if create else 0)
    flags |= os.O_EXCL if create and exclusive else os.O_TRUNC
    folder = os.open(path.parent, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    try:
        fd = os.open(path.name, flags, 0o644, dir_fd=folder)
    finally:
        os.close(folder)
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise OSError(f"{path.name} is not a regular file")
    os.set_blocking(fd, True)
    return fd


def check_writable(path: Path, *, exclusive: bool, min_free: int = MIN_FREE) -> None:
    """Create ``path`` (as :func:`open_file`) and write to it, so that a folder that cannot be
    written, a full disk or a name taken is refused before anything records; ValueError says
    which."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"cannot record to {path}: {exc.strerror or exc}") from None
    try:
        vfs = os.statvfs(path.parent)
        free = vfs.f_bavail * vfs.f_frsize
        if free < min_free:
            raise ValueError(f"cannot record to {path}: only {free // 1024} KiB free on its disk "
                             f"(at least {min_free // 1024} KiB needed)")
        fd = open_file(path, exclusive=exclusive)
    except FileExistsError:
        raise ValueError(f"{path.name} already exists in {path.parent}") from None
    except OSError as exc:
        raise ValueError(f"cannot record to {path}: {exc.strerror or exc}") from None
    try:
        os.write(fd, b"\x89MCAP0\r\n")  # the magic: the disk takes a block, or refuses now
        os.ftruncate(fd, 0)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(path)
        raise ValueError(f"cannot record to {path}: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


class DiskFile:
    """A written file as the ``mcap`` writer sees it (write, tell, flush). Each write is whole
    or not at all: when the disk refuses one (full, a size limit), the file is cut back to
    where that write began, so it ends with the last complete records, and the error is
    raised."""

    def __init__(self, fd: int):
        self.fd = fd
        self.pos = 0
        self.ends: deque[int] = deque(maxlen=32)  # where the last whole writes ended


    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data).cast("B")
        start, total = self.pos, len(view)
        try:
            while view:
                view = view[os.write(self.fd, view):]
        except OSError:
            self.cut(start)
            raise
        self.pos = start + total
        self.ends.append(self.pos)
        return total

    def cut(self, offset: int) -> None:
        """End the file at ``offset`` (freeing what a failed write left after it)."""
        with contextlib.suppress(OSError):
            os.ftruncate(self.fd, offset)
            os.lseek(self.fd, offset, os.SEEK_SET)
        self.pos = offset

    def tell(self) -> int:
        return self.pos

    def flush(self) -> None:
        """Writes go to the OS as they are made: nothing is held here."""

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


def recordings(folder: Path) -> list[tuple[Path, os.stat_result]]:
    """The ``*.mcap`` regular files directly in ``folder`` (not symlinks, not hidden), newest
    first."""
    found = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return []
    for entry in entries:
        if not entry.name.endswith(".mcap") or entry.name.startswith("."):
            continue
        with contextlib.suppress(OSError):
            st = entry.stat(follow_symlinks=False)
            if stat.S_ISREG(st.st_mode):
                found.append((Path(entry.path), st))
    found.sort(key=lambda f: f[1].st_mtime, reverse=True)
    return found


def prune(files: list[tuple[Path, int, float]], max_bytes: int, keep: set[Path]
          ) -> list[Path]:
    """Which of ``files`` (path, bytes, mtime) to remove, oldest first, to bring their total
    to ``max_bytes`` or under; those in ``keep`` (the file being written) never."""
    total = sum(size for _p, size, _t in files)
    remove = []
    for path, size, _mtime in sorted(files, key=lambda f: f[2]):
        if total <= max_bytes:
            break
        if path in keep:
            continue
        remove.append(path)
        total -= size
    return remove


def enforce_budget(folders: set[Path], own: list[Path], max_bytes: int, keep: set[Path]
                   ) -> int:
    """Remove the oldest recordings until they hold ``max_bytes`` or less: those of ``folders``
    (the recordings folder) and the parts ``own`` of the recording in progress (which may be
    elsewhere, ``--record FILE``); never a file of ``keep``. The bytes freed."""
    found = {p: st for folder in folders for p, st in recordings(folder)}
    for path in own:
        with contextlib.suppress(OSError):
            found.setdefault(path, path.lstat())
    files = [(p, st.st_size, st.st_mtime) for p, st in found.items()]
    freed = 0
    for path in prune(files, max_bytes, keep):
        try:
            os.unlink(path)
        except OSError as exc:
            log.warning("disk budget: cannot remove %s (%s)", path, exc.strerror or exc)
            continue
        freed += found[path].st_size
        log.info("disk budget: removed %s (%d kB) to keep recordings under %d MB", path.name,
                 found[path].st_size // 1000, max_bytes // 1_000_000)
    return freed


def make_room(folder: Path, prefix: str, max_bytes: int, incoming: int, reserve: int
              ) -> list[str]:
    """Before a file of at most ``incoming`` bytes joins the files of ``folder`` whose names
    start with ``prefix``: the oldest of those removed until they and it hold ``max_bytes`` or
    less; OSError when the disk would then keep less than ``reserve`` bytes free. The names
    removed."""
    files = [(p, st.st_size, st.st_mtime) for p, st in recordings(folder)
             if p.name.startswith(prefix)]
    removed = []
    for path in prune(files, max(0, max_bytes - incoming), set()):
        try:
            os.unlink(path)
        except OSError as exc:
            log.warning("disk budget: cannot remove %s (%s)", path, exc.strerror or exc)
            continue
        removed.append(path.name)
    vfs = os.statvfs(folder)
    free = vfs.f_bavail * vfs.f_frsize
    if free - incoming < reserve:
        raise OSError(f"only {free // 1024} KiB free on the disk of {folder}: a file of up to "
                      f"{incoming // 1024} KiB would leave less than the "
                      f"{reserve // (1024 * 1024)} MiB kept free")
    return removed

"""Map folders on disk: one folder per saved map under the store (``--map-dir``); the map
manager saves them and the map-files node reads them. Its name rule, atomic write and
containment check are also those of the route and graph folders (``namedfiles.py``).

A folder name is a plain name, never a path: it is validated before anything touches the disk,
and the resolved folder is checked to lie directly inside the store. Writing is atomic twice
over: each file goes to a temporary name, is flushed and ``os.replace``-d into place inside a
temporary folder, and only the finished folder is renamed to its final name (an older folder of
that name is moved aside first and removed after), so a crash never leaves a half-written map
under a real name.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
import unicodedata
from collections.abc import Mapping
from pathlib import Path

MAX_NAME_LENGTH = 64
_ALLOWED = re.compile(r"^[\w][\w.\- ]*$")
_TEMP_PREFIX = ".tmp-"
_OLD_PREFIX = ".old-"


class StoreError(ValueError):
    """A refused name or a failed store operation; the text is user-facing."""


def validate_name(name: str) -> str:
    """The folder name, or :class:`StoreError` saying what is wrong with it."""
    if not isinstance(name, str) or not name.strip():
        raise StoreError("map folder name must not be empty")
    if name.startswith(("/", "\\")) or re.match(r"^[A-Za-z]:[\\/]", name):
        raise StoreError(f"map folder name {name!r} must be a plain name, not an absolute path")
    if "/" in name or "\\" in name:
        raise StoreError(f"map folder name {name!r} must not contain path separators")
    if name in (".", "..") or name.startswith("."):
        raise StoreError(f"map folder name {name!r} must not start with '.'")
    if len(name) > MAX_NAME_LENGTH:
        raise StoreError(f"map folder name is too long ({len(name)} characters, at most "
                         f"{MAX_NAME_LENGTH})")
    if any(unicodedata.category(ch).startswith("C") for ch in name):
        raise StoreError(f"map folder name {name!r} must not contain control characters")
    if name != name.strip() or not _ALLOWED.match(name):
        raise StoreError(f"map folder name {name!r} may only use letters, digits, '_', '-', "
                         "'.' and inner spaces")
    return name


def inside(root: Path, entry: str) -> Path | None:
    """``root / entry`` resolved, or None when it does not lie directly inside ``root`` (a
    link pointing elsewhere): what keeps every store's names from leaving its folder."""
    root = root.resolve()
    path = (root / entry).resolve()
    return path if path.parent == root else None


def write_file(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically: a temporary file, flushed, then ``os.replace``."""
    tmp = path.with_name(f"{_TEMP_PREFIX}{path.name}.{secrets.token_hex(4)}")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def remove_leftovers(folder: Path, prefixes: tuple[str, ...] = (_TEMP_PREFIX,)) -> list[Path]:
    """Delete the entries of ``folder`` (files, or folders with what they hold) whose names
    start with one of ``prefixes``: what saves interrupted by a crash or kill -9 left behind.
    Only at start-up, when no save can be in progress; returns what was removed."""
    removed: list[Path] = []
    if not folder.is_dir():
        return removed
    for path in folder.iterdir():
        if not path.name.startswith(prefixes):
            continue
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                path.unlink()
        removed.append(path)
    return removed


def _fsync_dir(path: Path) -> None:
    with contextlib.suppress(OSError):
        fd = os.open(path, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


class MapStore:
    """The folder of map folders."""

    def __init__(self, root: Path | str):
        self.root = Path(root)

    def folder(self, name: str) -> Path:
        """The folder of map ``name`` (validated; guaranteed to be inside the store)."""
        path = inside(self.root, validate_name(name))
        if path is None:
            raise StoreError(f"map folder name {name!r} leaves the map store")
        return path

    def exists(self, name: str) -> bool:
        return self.folder(name).is_dir()

    def names(self) -> list[str]:
        if not self.root.is_dir():
            return []
        return sorted(p.name for p in self.root.iterdir()
                      if p.is_dir() and not p.name.startswith("."))

    def save(self, name: str, files: Mapping[str, bytes]) -> Path:
        """Write a whole map folder atomically; replaces an existing folder of that name."""
        final = self.folder(name)
        for filename in files:
            if "/" in filename or "\\" in filename or filename.startswith("."):
                raise StoreError(f"bad file name {filename!r}")
        try:
            self.root.mkdir(parents=True, exist_ok=True)
            root = final.parent
            tmp = root / f"{_TEMP_PREFIX}{name}.{secrets.token_hex(4)}"
            tmp.mkdir()
        except OSError as exc:
            raise StoreError(f"cannot write to the map store {self.root}: "
                             f"{exc.strerror or exc}") from None
        try:
            for filename, data in files.items():
                write_file(tmp / filename, data)
            _fsync_dir(tmp)
            old = None
            if final.exists():
                old = root / f"{_OLD_PREFIX}{name}.{secrets.token_hex(4)}"
                os.replace(final, old)
            os.replace(tmp, final)
            _fsync_dir(root)
        except OSError as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            raise StoreError(f"saving map {name!r} failed: {exc.strerror or exc}") from None
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        return final

    def clean_leftovers(self) -> list[str]:
        """Remove what an interrupted save left behind (``.tmp-*`` and ``.old-*`` folders and
        files in the store and in its map folders); returns the names removed. An ``.old-``
        folder whose map is missing (the crash fell between the two renames of :meth:`save`)
        is the only copy: it is renamed back instead. Run at start-up, when no save can be in
        progress."""
        removed: list[str] = []
        if not self.root.is_dir():
            return removed
        for path in self.root.glob(f"{_OLD_PREFIX}*"):
            name = path.name[len(_OLD_PREFIX):].rpartition(".")[0]
            with contextlib.suppress(StoreError, OSError):
                if path.is_dir() and not self.folder(name).exists():
                    os.replace(path, self.folder(name))
        folders = [self.root] + [p for p in self.root.iterdir()
                                 if p.is_dir() and not p.is_symlink()
                                 and not p.name.startswith(".")]
        for folder in folders:
            removed += (str(path.relative_to(self.root))
                        for path in remove_leftovers(folder, (_TEMP_PREFIX, _OLD_PREFIX)))
        return removed

    def read(self, name: str, filename: str) -> bytes:
        path = self.folder(name)
        if not path.is_dir():
            raise StoreError(f"there is no saved map named {name!r}")
        target = (path / filename).resolve()
        if not target.is_relative_to(self.root.resolve()):
            raise StoreError(f"map {name!r}: file {filename!r} is a link to outside the map store")
        try:
            return target.read_bytes()
        except FileNotFoundError:
            raise StoreError(f"map {name!r} has no file {filename!r}") from None
        except OSError as exc:
            raise StoreError(f"reading map {name!r} failed: {exc.strerror or exc}") from None

    def has_file(self, name: str, filename: str) -> bool:
        return (self.folder(name) / filename).is_file()

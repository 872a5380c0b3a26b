"""Folders of named YAML files (routes, graphs) shared by the nodes that store them.

:class:`NamedFiles` is a folder of ``<name>.yaml`` files (names validated by the map store's
own rule, atomic writes); the helpers read and write the versioned YAML documents and answer
the ``list_*_files`` services.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import yaml

from .mapstore import StoreError, inside, remove_leftovers, validate_name, write_file

SUFFIX = ".yaml"


class FileError(ValueError):
    """A refused file name or an unreadable file; the text is user-facing."""


def check_name(name: str) -> str:
    """A file name validated by the map store's rule (plain name, no path, ≤ 64 chars)."""
    try:
        return validate_name(name)
    except StoreError as exc:
        raise FileError(str(exc).replace("map folder name", "file name")) from None


class NamedFiles:
    """A folder of ``<name>.yaml`` files; names never leave the folder."""

    def __init__(self, root: Path | str):
        self.root = Path(root)

    def clean_leftovers(self) -> list[str]:
        """Remove the temporary files of writes a crash interrupted (at start-up only)."""
        return [path.name for path in remove_leftovers(self.root)]

    def path(self, name: str) -> Path:
        path = inside(self.root, check_name(name) + SUFFIX)
        if path is None:
            raise FileError(f"file name {name!r} leaves the store")
        return path

    def names(self) -> list[str]:
        if not self.root.is_dir():
            return []
        return sorted(p.name[: -len(SUFFIX)] for p in self.root.iterdir()
                      if p.is_file() and p.name.endswith(SUFFIX) and not p.name.startswith("."))

    def exists(self, name: str) -> bool:
        return self.path(name).is_file()

    def write(self, name: str, data: bytes) -> Path:
        path = self.path(name)
        try:
            self.root.mkdir(parents=True, exist_ok=True)
            write_file(path, data)
        except OSError as exc:
            raise FileError(f"cannot write {path}: {exc.strerror or exc}") from None
        return path

    def read(self, name: str) -> bytes:
        try:
            return self.path(name).read_bytes()
        except FileNotFoundError:
            raise FileError(f"File not found: {name}") from None
        except OSError as exc:
            raise FileError(f"cannot read {name!r}: {exc.strerror or exc}") from None


def is_default_dir(root: Path, directory: str) -> bool:
    """``directory`` names the store folder ``root``: empty (the default) or its own path."""
    if not directory.strip():
        return True
    try:
        return Path(directory).expanduser().resolve() == root.resolve()
    except (OSError, ValueError):
        return False


def list_reply(root: Path, directory: str, names: Callable[[], list[str]]) -> dict:
    """The answer of a ``list_*_files`` service: only the store's own folder is listed."""
    if not is_default_dir(root, directory):
        return {"success": False, "files": [],
                "message": f"only the default directory can be listed ({root}); "
                           "give an empty directory"}
    try:
        files = names()
    except OSError as exc:
        return {"success": False, "files": [], "message": f"cannot list {root}: {exc}"}
    return {"success": True, "message": f"Found {len(files)} files", "files": files}


def dump_yaml(kind: str, doc: dict) -> bytes:
    head = f"# hitrobot-server {kind}\n"
    return (head + yaml.safe_dump({"version": 1, **doc}, sort_keys=False)).encode()


def load_yaml(data: bytes, what: str) -> dict:
    try:
        doc = yaml.safe_load(data.decode("utf-8"))
    except (UnicodeDecodeError, yaml.YAMLError) as exc:
        raise FileError(f"{what} is not valid YAML: {exc}") from None
    if not isinstance(doc, dict) or doc.get("version") != 1:
        raise FileError(f"{what} is not a version 1 hitrobot-server file")
    return doc


def number(value: object, path: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise FileError(f"field '{path}' must be a finite number")
    return float(value)

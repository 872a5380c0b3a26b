"""The one safe spelling of a recording's name (sans-I/O): a name a client gives
``/record/start`` becomes a file in the recordings folder, is listed in the console, downloaded
and replayed, so it holds only what is harmless everywhere — ASCII letters, digits, ``-``,
``_``, ``.``, not first a dot or a dash (no hidden file, no option to a shell command), no
``..``, no Windows device name, at most :data:`MAX_NAME` characters with ``.mcap``."""

from __future__ import annotations

import re

MAX_NAME = 64
EXTENSION = ".mcap"
_SPELLING = re.compile(r"[A-Za-z0-9._-]*", re.ASCII)
_DEVICES = frozenset({"con", "prn", "aux", "nul", "conin$", "conout$",
                      *(f"com{i}" for i in range(10)), *(f"lpt{i}" for i in range(10))})


def recording_name(name: str, default: str) -> str:
    """The file name (``*.mcap``) of a recording a client named ``name`` (``""``:
    ``default``); ValueError says what is wrong with it."""
    name = name or default
    if not name.endswith(EXTENSION):
        name += EXTENSION
    stem = name[: -len(EXTENSION)]
    if not _SPELLING.fullmatch(name):
        bad = next(c for c in name if not _SPELLING.fullmatch(c))
        raise ValueError(f"field 'name' may hold only letters, digits, '-', '_' and '.', "
                         f"not {bad!r}")
    if not stem:
        raise ValueError("field 'name' is empty")
    if name[0] in ".-":
        raise ValueError(f"field 'name' must not start with {name[0]!r}")
    if ".." in name:
        raise ValueError("field 'name' must not hold '..'")
    if stem.split(".")[0].lower() in _DEVICES:
        raise ValueError(f"field 'name' must not be a device name ({stem.split('.')[0]!r})")
    if len(name) > MAX_NAME:
        raise ValueError(f"field 'name' is longer than {MAX_NAME} characters "
                         f"({len(name)} with {EXTENSION})")
    return name

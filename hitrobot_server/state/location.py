"""Where a robot's state folder is: ``<root>/<robot identity>/``."""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path

_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


def default_root() -> Path:
    """``$XDG_STATE_HOME/hitrobot-server`` (``~/.local/state/hitrobot-server``)."""
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "hitrobot-server"


def user_data(name: str) -> Path:
    """``$XDG_DATA_HOME/hitrobot-server/NAME`` (``~/.local/share`` when unset)."""
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "hitrobot-server" / name


def identity_folder(root: Path, identity: str) -> Path:
    """The folder of one robot identity: a plain, readable folder name (no path tricks), so
    two identities never share a folder."""
    name = _UNSAFE.sub("_", identity).strip("._")[:80] or "robot"
    if name != identity:  # "a/b" and "a_b" must not meet in one folder
        name += "-" + hashlib.sha256(identity.encode()).hexdigest()[:10]
    return Path(root) / name

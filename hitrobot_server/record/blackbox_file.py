"""A black-box file: the buffer's messages, written through the recorder's writer
(:class:`~hitrobot_server.record.writer.McapFiles`, so it is the same ROS 2 MCAP a recording
is), with the incident in a metadata record; and reading that record back for the list.

The file is written under a hidden name and renamed when whole, so the recordings list never
shows half a file. Names start with ``blackbox-``: the list reads the metadata of those only
(a recording being written has no summary yet, and reading one would scan it whole).
"""

from __future__ import annotations

import contextlib
import datetime
import os
import re
from dataclasses import dataclass
from pathlib import Path

from mcap.reader import make_reader

from .writer import Counters, Item, McapFiles

PREFIX = "blackbox-"
METADATA = "hitrobot.incident"
CHUNK_SPAN = 1.0  # seconds of log time per chunk, as a recording's


@dataclass(frozen=True)
class Incident:
    """Why a black-box file was written."""

    cause: str  # link_lost, goal_aborted, localization_lost, emergency_stop, shutdown, snapshot
    detail: str
    time: float  # UNIX seconds

    @property
    def metadata(self) -> dict[str, str]:
        return {"cause": self.cause, "detail": self.detail, "time": repr(self.time),
                "utc": datetime.datetime.fromtimestamp(self.time, datetime.UTC).isoformat()}


class _Count:
    """A counter of the writer's, kept in this process (the writer's are shared memory)."""

    __slots__ = ("value",)

    def __init__(self) -> None:
        self.value = 0


def file_name(incident: Incident, folder: Path) -> str:
    """``blackbox-YYYYMMDD-HHMMSS-CAUSE.mcap``, numbered when that name is taken."""
    when = datetime.datetime.fromtimestamp(incident.time, datetime.UTC)
    cause = re.sub(r"[^a-z0-9_]+", "_", incident.cause.lower())[:24] or "incident"
    stem = f"{PREFIX}{when:%Y%m%d-%H%M%S}-{cause}"
    name, n = f"{stem}.mcap", 1
    while (folder / name).exists():
        name, n = f"{stem}-{n}.mcap", n + 1
    return name


def write_black_box(folder: Path, items: list[Item], incident: Incident) -> str:
    """Write ``items`` and the incident to a new file of ``folder``; its name. Blocking: run
    it in a thread (the items are CDR already, so it only frames and compresses)."""
    folder.mkdir(parents=True, exist_ok=True)
    name = file_name(incident, folder)
    hidden = folder / f".{name}.part"
    files = McapFiles(hidden, 0, Counters(*(_Count() for _ in range(6))), CHUNK_SPAN)
    try:
        files.writer.add_metadata(METADATA, incident.metadata)
        files.write_all(items)
    finally:
        files.finish()
    try:
        os.replace(hidden, folder / name)
    except OSError:
        with contextlib.suppress(OSError):
            hidden.unlink()
        raise
    return name


def read_incident(path: Path) -> Incident | None:
    """The incident a black-box file names, None when it names none or cannot be read."""
    try:
        with path.open("rb") as f:
            for record in make_reader(f).iter_metadata():
                if record.name == METADATA:
                    m = record.metadata
                    return Incident(m.get("cause", ""), m.get("detail", ""),
                                    float(m.get("time", "0") or 0))
    except Exception:  # a damaged or foreign file names no incident (mcap raises its own kinds)
        return None
    return None

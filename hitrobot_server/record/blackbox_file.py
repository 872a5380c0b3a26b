"""A black-box file: the buffer's messages, written through the recorder's writer
(:func:`~hitrobot_server.record.writer.write_recording`, so it is the same ROS 2 MCAP a
recording is), with the incident in a metadata record; and reading that record back for the list.

It is written in a process of its own (:class:`FileWriter`, started with the black box and
kept): framing thousands of messages in a thread of the server holds the GIL against the event
loop. The rows cross as plain tuples of bytes, which pickle in C, in batches.

The file is written under a hidden name and renamed when whole, so the recordings list never
shows half a file. Names start with ``blackbox-``: the list reads the metadata of those only
(a recording being written has no summary yet, and reading one would scan it whole).
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import multiprocessing
import os
import queue
import re
import signal
import threading
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from .handoff import CDR, Item
from .writer import WRITER_NICENESS, write_recording

PREFIX = "blackbox-"
METADATA = "hitrobot.incident"
BATCH = 256  # rows per put to the writer process
CLOSE_TIMEOUT = 10.0

Row = tuple[str, str, bool, int, int, int, bytes]
"""One kept message: topic, type, latched, log time (ns), publish time (ns), seq, CDR."""


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


def file_name(incident: Incident, folder: Path) -> str:
    """``blackbox-YYYYMMDD-HHMMSS-CAUSE.mcap``, numbered when that name is taken."""
    when = datetime.datetime.fromtimestamp(incident.time, datetime.UTC)
    cause = re.sub(r"[^a-z0-9_]+", "_", incident.cause.lower())[:24] or "incident"
    stem = f"{PREFIX}{when:%Y%m%d-%H%M%S}-{cause}"
    name, n = f"{stem}.mcap", 1
    while (folder / name).exists():
        name, n = f"{stem}-{n}.mcap", n + 1
    return name


def write_black_box(folder: Path, rows: Iterable[Row], incident: Incident) -> str:
    """Write ``rows`` and the incident to a new file of ``folder``; its name. Blocking: the
    file writer's process runs it (the rows are CDR already: it only frames and compresses)."""
    folder.mkdir(parents=True, exist_ok=True)
    name = file_name(incident, folder)
    hidden = folder / f".{name}.part"
    items = (Item(topic, type_name, latched, log_time, publish_time, seq, CDR, cdr)
             for topic, type_name, latched, log_time, publish_time, seq, cdr in rows)
    try:
        write_recording(hidden, items, metadata=incident.metadata, metadata_name=METADATA)
        os.replace(hidden, folder / name)
    except BaseException:  # no half file left behind, not even a hidden one
        with contextlib.suppress(OSError):
            hidden.unlink()
        raise
    return name


def _start_writer() -> None:
    """In the writer process: after the event loop, deaf to the signals a terminal or
    systemd sends the whole group (the server says when to stop: a shutdown file is written
    after SIGTERM), and gone when the server is."""
    with contextlib.suppress(OSError, AttributeError):
        os.nice(WRITER_NICENESS)
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)
    server = multiprocessing.parent_process()
    if server is not None:
        threading.Thread(target=lambda: (server.join(), os._exit(0)), name="watch-server",
                         daemon=True).start()


def run_file_writer(jobs: Any, done: Any) -> None:
    """The writer process: for each job (a folder and an incident, then batches of rows, then
    an empty batch) write the file and put ``("ok", name)`` or ``("error", text)``; ``None``
    ends it."""
    _start_writer()
    while (job := jobs.get()) is not None:
        folder, incident = job
        rows = _batches(jobs)  # written as they come: the process holds one batch at a time
        try:
            done.put(("ok", write_black_box(folder, rows, incident)))
        except Exception as exc:  # reported to the server, which logs it and goes on
            done.put(("error", f"{type(exc).__name__}: {exc}"))
        for _rest in rows:  # what a failed write left in the queue is not the next job
            pass


def _batches(jobs: Any) -> Iterator[Row]:
    while batch := jobs.get():
        yield from batch


class FileWriter:
    """The process that writes black-box files, one at a time. :meth:`start` has it ready
    before the first incident (a spawned process takes seconds to import what it needs, and
    an incident, a SIGTERM above all, should not wait for that). Rows cross in batches: the
    queue's feeder thread pickles each apart, so it never holds the GIL for a whole buffer
    (one pickle of 60 s of the simulator stalled the loop for 470 ms)."""

    def __init__(self) -> None:
        self._ctx = multiprocessing.get_context("spawn")  # the server has threads: no fork
        self._process: Any = None
        self._jobs: Any = None
        self._done: Any = None

    def start(self) -> None:
        if self._process is not None and self._process.is_alive():
            return
        self._jobs, self._done = self._ctx.Queue(), self._ctx.Queue()
        self._process = self._ctx.Process(target=run_file_writer, args=(self._jobs, self._done),
                                          name="blackbox-writer", daemon=True)
        self._process.start()

    async def write(self, folder: Path, rows: list[Row], incident: Incident) -> str:
        """The new file's name; OSError when it cannot be written."""
        self.start()
        self._jobs.put((folder, incident))
        for i in range(0, len(rows), BATCH):
            self._jobs.put(rows[i:i + BATCH])
        self._jobs.put([])
        status, value = await asyncio.to_thread(self._result)
        if status != "ok":
            raise OSError(value)
        return value

    def _result(self) -> tuple[str, str]:
        while True:
            try:
                return self._done.get(timeout=1.0)
            except queue.Empty:
                if not self._process.is_alive():
                    return "error", "the black box's writer process ended"

    async def close(self) -> None:
        process, self._process = self._process, None
        if process is None:
            return
        if process.is_alive():
            self._jobs.put(None)
        await asyncio.to_thread(process.join, CLOSE_TIMEOUT)
        if process.is_alive():
            process.kill()
        self._jobs.close()
        self._done.close()


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

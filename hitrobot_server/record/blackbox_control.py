"""The black box on the bus: ``/record/snapshot`` writes it now, an incident writes it by
itself, ``/record/incidents`` lists the files with their causes, and the latched
``/record/incident`` says which file the latest incident left.

Why a topic of its own and not a field of ``/record/state``: that message is the recording in
progress, republished every second; an incident is an event that a console opened later
should still see, so it is latched apart (and ``RecordState`` keeps the definition its readers
and earlier recordings have).

The files count against a disk budget of their own, :data:`DISK_FILES` times the buffer's
bound (``--black-box-max-mb``: 1 GiB by default), the oldest going first, and a file is not
written when it would leave the disk less than :data:`RESERVE` free (it says so). Snapshots
asked for while one is being written share it (a flood of ``/record/snapshot`` is one file
at a time, and one copy of the buffer's rows: the rows are taken when a file's turn comes).

One incident makes one file: an incident waits ``GATHER`` seconds before it is written, and
every other cause reported meanwhile (the link lost, then the goal it aborted) joins the same
file; the same cause again within ``QUIET`` seconds of its file is the same incident.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from pathlib import Path

from ..bus.core import Bus
from ..bus.errors import ServiceError
from .blackbox import BlackBox
from .blackbox_file import PREFIX, FileWriter, Incident, read_incident
from .control import list_recordings
from .files import make_room
from .incidents import IncidentWatch

log = logging.getLogger(__name__)

NODE = "/black_box"
INCIDENT_TOPIC = "/record/incident"
GATHER = 1.0
QUIET = 30.0
MAX_REASON = 200
DISK_FILES = 16
"""The black box's files may hold this many times its buffer's bound on disk."""
QUIET_CAUSES = frozenset({"snapshot", "shutdown"})
"""Files written on request, not on an incident: logged at INFO."""
RESERVE = 64 * 1024 * 1024
"""Bytes a black-box file must leave free on its disk."""


class BlackBoxControl:
    """Owns the black box and the incident watch; writes the files."""

    def __init__(self, bus: Bus, folder: Path, *, seconds: float, max_bytes: int,
                 topics: str | None = None, localization_threshold: int = 30,
                 disk_bytes: int | None = None, reserve: int = RESERVE):
        self.bus = bus
        self.folder = folder
        self.disk_bytes = DISK_FILES * max_bytes if disk_bytes is None else disk_bytes
        self.reserve = reserve
        self._snapshotting: asyncio.Future[str] | None = None  # the snapshot being written
        self.box = BlackBox(bus, seconds, max_bytes, topics=topics)
        self.watch = IncidentWatch(self.report, localization_threshold=localization_threshold)
        self.writer = FileWriter()
        self.count = 0
        self.suppressed = 0
        self._pending: list[tuple[str, str]] | None = None
        self._pending_time = 0.0
        self._timer: asyncio.Task | None = None
        self._last: dict[str, float] = {}  # cause → monotonic time of its last file
        self._writing = asyncio.Lock()
        self._stopping = False
        self._listed: dict[tuple[str, int, int], Incident | None] = {}

    async def start(self) -> None:
        bus = self.bus
        bus.register_node(NODE)
        bus.advertise(INCIDENT_TOPIC, "hitrobot_msgs/RecordIncident", self, NODE, latch=True)
        bus.advertise_service("/record/snapshot", "hitrobot_msgs/RecordSnapshot", self, NODE,
                              self._snapshot)
        bus.advertise_service("/record/incidents", "hitrobot_msgs/ListIncidents", self, NODE,
                              self._list)
        self.writer.start()
        self.box.start()  # first: the message that reports an incident is in the buffer
        bus.taps.append(self.watch)
        self._publish(Incident("", "", 0.0), "")  # none yet: a console sees the box is on
        log.info("black box: the last %g s of the recorded topics (at most %d MiB)",
                 self.box.seconds, self.box.max_bytes // (1024 * 1024))

    def shutting_down(self) -> None:
        """The server stops: what its parts do now (links closing) is no incident."""
        self._stopping = True
        if self.watch in self.bus.taps:
            self.bus.taps.remove(self.watch)
        if self._timer is not None and self._pending is not None:  # still gathering
            self._timer.cancel()

    async def stop(self) -> None:
        """Write the ``shutdown`` file (with any incident still gathering), then leave."""
        self.shutting_down()
        if self._timer is not None:  # an incident being written is finished first
            with contextlib.suppress(asyncio.CancelledError):
                await self._timer
        causes = [*(self._pending or []), ("shutdown", "the server was told to stop")]
        self._pending = None
        with contextlib.suppress(OSError):
            await self._write(_incident(causes, time.time()))
        self.box.stop()
        await self.writer.close()
        self.bus.remove_owner(self)
        self.bus.unregister_node(NODE)

    # ------------------------------------------------------------------ incidents
    def report(self, cause: str, detail: str) -> None:
        """An incident seen on the bus (called on the loop by the watch)."""
        if self._stopping:
            return
        if self._pending is not None:
            self._pending.append((cause, detail))
            return
        if time.monotonic() - self._last.get(cause, float("-inf")) < QUIET:
            self.suppressed += 1
            return
        log.warning("black box: incident %s (%s)", cause, detail)
        self._pending, self._pending_time = [(cause, detail)], time.time()
        self._timer = asyncio.ensure_future(self._gathered())

    async def _gathered(self) -> None:
        await asyncio.sleep(GATHER)
        causes, self._pending = self._pending or [], None
        now = time.monotonic()
        for cause, _detail in causes:
            self._last[cause] = now
        with contextlib.suppress(OSError):  # logged and published by _write
            await self._write(_incident(causes, self._pending_time))

    async def _write(self, incident: Incident) -> str:
        """Write the buffer as it is now; the file's name. OSError when it cannot be."""
        async with self._writing:
            try:
                await asyncio.to_thread(self._make_room)
                items = self.box.snapshot()  # the rows now, when its turn came
                name = await self.writer.write(self.folder, items, incident)
            except OSError as exc:
                log.error("black box: %s not written: %s", incident.cause, exc)
                self._publish(incident, "")
                raise
            self.count += 1
        # an incident is a warning; a snapshot asked for (or the shutdown file) is news
        level = logging.INFO if incident.cause in QUIET_CAUSES else logging.WARNING
        log.log(level, "black box: %s: %d messages written to %s", incident.cause, len(items),
                name)
        self._publish(incident, name)
        return name

    def _make_room(self) -> None:
        """The oldest black-box files removed to keep the budget with the next one (at most
        the buffer's bytes and each message's framing); OSError past the disk's reserve."""
        self.folder.mkdir(parents=True, exist_ok=True)
        contents = self.box.contents
        incoming = contents.bytes + 64 * contents.messages + 1024 * 1024
        for name in make_room(self.folder, PREFIX, self.disk_bytes, incoming, self.reserve):
            log.info("black box: %s removed (the black box's files are kept under %d MiB)",
                     name, self.disk_bytes // (1024 * 1024))

    def _publish(self, incident: Incident, name: str) -> None:
        self.bus.publish(INCIDENT_TOPIC, {
            "cause": incident.cause, "detail": incident.detail, "file": name,
            "time": incident.time, "count": self.count})

    # ------------------------------------------------------------------ services
    async def _snapshot(self, request: dict) -> dict:
        reason = str(request.get("reason", "")).strip()
        if len(reason) > MAX_REASON:
            raise ServiceError(f"field 'reason' is longer than {MAX_REASON} characters")
        contents = self.box.contents
        writing = self._snapshotting
        if writing is None or writing.done():  # else: this one shares the file being written
            writing = self._snapshotting = asyncio.ensure_future(
                self._write(Incident("snapshot", reason or "asked for", time.time())))
        try:
            name = await asyncio.shield(writing)
        except OSError as exc:
            raise ServiceError(f"the black box could not be written: {exc}") from None
        return {"success": True, "path": name,
                "message": f"{contents.messages} messages ({contents.seconds:.1f} s, "
                           f"{contents.bytes / 1e6:.1f} MB) written to {name}"}

    async def _list(self, _request: dict) -> dict:
        rows = await asyncio.to_thread(self._incidents)
        return {"files": [r[0] for r in rows], "causes": [r[1].cause for r in rows],
                "details": [r[1].detail for r in rows], "times": [r[1].time for r in rows],
                "sizes": [r[2] for r in rows]}

    def _incidents(self) -> list[tuple[str, Incident, int]]:
        """The black-box files, newest first, with their incidents (cached by name, mtime
        and size: a file is read once)."""
        rows = []
        seen = {}
        for name, size in list_recordings(self.folder):
            if not name.startswith(PREFIX):
                continue
            path = self.folder / name
            try:
                key = (name, path.stat().st_mtime_ns, size)
            except OSError:
                continue
            incident = self._listed[key] if key in self._listed else read_incident(path)
            seen[key] = incident
            if incident is not None:
                rows.append((name, incident, size))
        self._listed = seen
        return rows


def _incident(causes: list[tuple[str, str]], when: float) -> Incident:
    """One incident of the causes gathered: the first names it, every detail is kept."""
    details = list(dict.fromkeys(f"{cause}: {detail}" if i else detail
                                 for i, (cause, detail) in enumerate(causes)))
    return Incident(causes[0][0], "; ".join(details), when)

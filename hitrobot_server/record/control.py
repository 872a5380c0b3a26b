"""Recording from the console: ``/record/start``, ``/record/stop``, ``/record/list`` and the
latched ``/record/state``. One recording runs at a time (``--record FILE`` counts as one);
files started from a client go to the recordings folder, which HTTP serves for download."""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import logging
from pathlib import Path

from ..bus.core import Bus
from ..bus.errors import ServiceError
from .recorder import Recorder

log = logging.getLogger(__name__)

NODE = "/recorder"
STATE_TOPIC = "/record/state"
STATE_PERIOD = 1.0
MAX_NAME = 64


def recording_name(name: str) -> str:
    """A plain ``*.mcap`` file name from a client's ``name``; ValueError says what is wrong."""
    name = name.strip() or datetime.datetime.now(datetime.UTC).strftime("rec-%Y%m%d-%H%M%S")
    if not name.endswith(".mcap"):
        name += ".mcap"
    if "/" in name or "\\" in name or "\0" in name or name.startswith("."):
        raise ValueError(f"field 'name' must be a plain file name, not {name!r}")
    if len(name) > MAX_NAME:
        raise ValueError(f"field 'name' is longer than {MAX_NAME} characters")
    return name


def list_recordings(folder: Path) -> list[tuple[str, int]]:
    """The MCAP files of the recordings folder (name, bytes), newest first."""
    if not folder.is_dir():
        return []
    files = [(p.stat(), p.name) for p in folder.iterdir()
             if p.suffix == ".mcap" and p.is_file() and not p.name.startswith(".")]
    files.sort(key=lambda f: f[0].st_mtime, reverse=True)
    return [(name, stat.st_size) for stat, name in files]


class RecordingControl:
    """The recorder services on the bus; owns the recording in progress."""

    def __init__(self, bus: Bus, folder: Path, *, topics: str | None = None,
                 split_size: int = 0):
        self.bus = bus
        self.folder = folder
        self.topics = topics
        self.split_size = split_size
        self.recorder: Recorder | None = None
        self._task: asyncio.Task | None = None
        self._busy = asyncio.Lock()

    def start_recording(self, path: Path) -> None:
        """Start recording to ``path`` (raises ValueError when it cannot be written)."""
        recorder = Recorder(self.bus, path, topics=self.topics, split_size=self.split_size)
        recorder.start()
        self.recorder = recorder

    async def start(self) -> None:
        bus = self.bus
        bus.register_node(NODE)
        bus.advertise(STATE_TOPIC, "hitrobot_msgs/RecordState", self, NODE, latch=True)
        bus.advertise_service("/record/start", "hitrobot_msgs/RecordStart", self, NODE,
                              self._start)
        bus.advertise_service("/record/stop", "std_srvs/Trigger", self, NODE, self._stop)
        bus.advertise_service("/record/list", "hitrobot_msgs/ListRecordings", self, NODE,
                              self._list)
        self._publish_state()
        self._task = asyncio.ensure_future(self._report())

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        if self.recorder is not None:
            await self.recorder.stop()
            self.recorder = None
        self.bus.remove_owner(self)
        self.bus.unregister_node(NODE)

    async def _report(self) -> None:
        while True:
            await asyncio.sleep(STATE_PERIOD)
            if self.recorder is None:
                continue
            if not self.recorder.alive:
                async with self._busy:
                    recorder, self.recorder = self.recorder, None
                    if recorder is not None:
                        log.error("recording to %s stopped: its writer process ended (exit "
                                  "code %s)", recorder.path, recorder.exit_code)
                        await recorder.stop()
            self._publish_state()

    def _publish_state(self) -> None:
        r = self.recorder
        self.bus.publish(STATE_TOPIC, {
            "recording": r is not None,
            "file": r.files[-1].name if r is not None and r.files else "",
            "bytes": r.bytes if r is not None else 0,
            "messages": r.messages if r is not None else 0,
            "dropped": r.dropped if r is not None else 0,
        })

    async def _start(self, request: dict) -> dict:
        async with self._busy:
            if self.recorder is not None:
                raise ServiceError(f"already recording to {self.recorder.path.name}")
            try:
                name = recording_name(str(request.get("name", "")))
                path = self.folder / name
                if path.exists():
                    raise ValueError(f"{name} already exists in the recordings folder")
                self.start_recording(path)
            except ValueError as exc:
                raise ServiceError(str(exc)) from None
            self._publish_state()
            return {"success": True, "file": name, "message": f"recording to {name}"}

    async def _stop(self, _request: dict) -> dict:
        async with self._busy:
            recorder = self.recorder
            if recorder is None:
                raise ServiceError("not recording")
            await recorder.stop()
            self.recorder = None
            self._publish_state()
            return {"success": True,
                    "message": f"recorded {recorder.messages} messages to "
                               f"{', '.join(p.name for p in recorder.files)}"
                               + (f" ({recorder.dropped} dropped)" if recorder.dropped else "")}

    async def _list(self, _request: dict) -> dict:
        files = await asyncio.to_thread(list_recordings, self.folder)
        return {"files": [name for name, _size in files], "sizes": [size for _name, size in files]}

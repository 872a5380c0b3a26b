"""Recording from the console: ``/record/start``, ``/record/stop``, ``/record/list`` and the
latched ``/record/state``. One recording runs at a time (``--record FILE`` counts as one);
files started from a client go to the recordings folder, which HTTP serves for download."""

from __future__ import annotations

import asyncio
import contextlib
import datetime
import logging
import os
from pathlib import Path

from ..bus.core import Bus
from ..bus.errors import ServiceError
from .files import recordings
from .names import recording_name
from .recorder import Recorder

log = logging.getLogger(__name__)

NODE = "/recorder"
STATE_TOPIC = "/record/state"
STATE_PERIOD = 1.0


def list_recordings(folder: Path) -> list[tuple[str, int]]:
    """The MCAP files of the recordings folder (name, bytes), newest first."""
    return [(path.name, st.st_size) for path, st in recordings(folder)]


def default_name() -> str:
    return datetime.datetime.now(datetime.UTC).strftime("rec-%Y%m%d-%H%M%S")


class RecordingControl:
    """The recorder services on the bus; owns the recording in progress."""

    def __init__(self, bus: Bus, folder: Path, *, topics: str | None = None,
                 split_size: int = 0, split_time: float = 0.0, max_disk: int = 0):
        self.bus = bus
        self.folder = folder
        self.topics = topics
        self.split_size = split_size
        self.split_time = split_time
        self.max_disk = max_disk
        self.recorder: Recorder | None = None
        self._task: asyncio.Task | None = None
        self._busy = asyncio.Lock()

    def start_recording(self, path: Path, *, exclusive: bool = False) -> None:
        """Start recording to ``path`` (raises ValueError when it cannot be written);
        ``exclusive``: a file of that name is refused (a client's), else emptied (the
        operator's ``--record FILE``). The disk budget covers the recordings folder and the
        parts of this recording."""
        recorder = Recorder(self.bus, path, topics=self.topics, split_size=self.split_size,
                            split_time=self.split_time, max_disk=self.max_disk,
                            budget_folder=self.folder, exclusive=exclusive)
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
                async with self._busy:  # /record/stop may have ended it meanwhile
                    recorder = self.recorder
                    if recorder is not None and not recorder.alive:
                        self.recorder = None
                        cause = (os.strerror(recorder.disk_error) if recorder.disk_error
                                 else f"its writer process ended (exit code "
                                      f"{recorder.exit_code})")
                        log.error("recording to %s stopped: %s", recorder.path, cause)
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
                name = recording_name(str(request.get("name", "")), default_name())
                self.start_recording(self.folder / name, exclusive=True)
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

"""``/record/replay``: a recording of the folder served by ``hitrobot-server replay`` on a port
of its own, so the console opens it in a tab beside the live robot (the live server's bus is
the robot's; a replay needs a bus of its own). One replay runs at a time; it ends with the
server or when another one is asked for."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

from ..bus.core import Bus
from ..bus.errors import ServiceError
from ..signals import PARENT_DIR
from .names import recording_name

log = logging.getLogger(__name__)

NODE = "/replay_launcher"
START_TIMEOUT = 30.0
STOP_TIMEOUT = 5.0
BANNER = re.compile(r"wss?://\S+:(\d+)")


class ReplayLauncher:
    """Starts and stops the one replay process."""

    def __init__(self, bus: Bus, folder: Path, address: str, flags: list[str] | None = None):
        """``flags``: added to the replay's command line (``--authenticate`` and its tokens:
        the replay answers the same tokens as this server)."""
        self.bus = bus
        self.folder = folder
        self.address = address
        self.flags = list(flags or ())
        self.process: asyncio.subprocess.Process | None = None
        self.port = 0
        self._state_dir: str | None = None
        self._drain: asyncio.Task | None = None
        self._busy = asyncio.Lock()

    async def start(self) -> None:
        self.bus.register_node(NODE)
        self.bus.advertise_service("/record/replay", "hitrobot_msgs/ReplayRecording", self,
                                   NODE, self._replay)

    async def stop(self) -> None:
        async with self._busy:
            await self._end()
        self.bus.remove_owner(self)
        self.bus.unregister_node(NODE)

    async def _replay(self, request: dict) -> dict:
        try:  # validate before anything stops or starts
            name = recording_name(str(request.get("name", "")), "")
        except ValueError as exc:
            raise ServiceError(str(exc)) from None
        path = self.folder / name
        if not path.is_file():
            raise ServiceError(f"field 'name': no recording {name} in the recordings folder")
        async with self._busy:
            await self._end()
            port = await self._launch(path)
        return {"success": True, "port": port,
                "message": f"replaying {name} on port {port}"}

    async def _launch(self, path: Path) -> int:
        self._state_dir = tempfile.mkdtemp(prefix="hitrobot-replay-")
        self.process = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "hitrobot_server", "replay", str(path), "--port", "0",
            "--tcp-port", "0", "--address", self.address, "--robot", "none",
            "--state-dir", self._state_dir, "--record-dir", str(self.folder),
            "--black-box", "0",  # a config file's black box is the live server's, not this
            *self.flags,
            # stdin a pipe from us: its end (we died, even by kill -9) stops the replay, which
            # then removes its folder (PARENT_DIR) and its own children die with it
            stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.STDOUT, env={**os.environ, PARENT_DIR: self._state_dir})
        try:
            port = await asyncio.wait_for(self._banner(), START_TIMEOUT)
        except (TimeoutError, ValueError) as exc:
            output = str(exc) or f"no answer in {START_TIMEOUT:g} s"
            await self._end()
            raise ServiceError(f"the replay of {path.name} did not start: {output}") from None
        self.port = port
        self._drain = asyncio.ensure_future(_log_output(self.process))
        log.info("replaying %s on port %d (pid %d)", path.name, port, self.process.pid)
        return port

    async def _banner(self) -> int:
        """The replay's port, from the line it prints once it listens; ValueError with its
        last line when it ends first."""
        assert self.process is not None and self.process.stdout is not None
        last = ""
        while line := (await self.process.stdout.readline()).decode(errors="replace"):
            if match := BANNER.search(line):
                return int(match.group(1))
            last = line.strip() or last
        raise ValueError(last or "it ended")

    async def _end(self) -> None:
        process, self.process, self.port = self.process, None, 0
        if process is not None and process.returncode is None:
            process.terminate()
            try:
                await asyncio.wait_for(process.wait(), STOP_TIMEOUT)
            except TimeoutError:
                process.kill()
                await process.wait()
        if self._drain is not None:
            self._drain.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._drain
            self._drain = None
        if self._state_dir is not None:
            shutil.rmtree(self._state_dir, ignore_errors=True)
            self._state_dir = None


async def _log_output(process: asyncio.subprocess.Process) -> None:
    """The replay's output after its banner, read so its pipe never fills."""
    assert process.stdout is not None
    while line := await process.stdout.readline():
        log.debug("replay: %s", line.decode(errors="replace").rstrip())

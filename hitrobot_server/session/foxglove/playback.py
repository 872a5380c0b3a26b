"""Foxglove's timeline drives a replay (``hitrobot-server replay``): the ``playbackControl``
capability on the replay's own services and state.

A server that replays has ``/replay/seek`` and the latched ``/replay/state``; a client that
connects to it is told the data's start and end in ``serverInfo``. Its Playback Control Requests
become calls of ``/replay/set_speed``, ``/replay/seek``, ``/replay/pause`` and
``/replay/resume`` (the same services rosbridge clients and the console use, so every client
sees one replay), answered by a Playback State; a change made by anyone else (the end reached,
another client pausing) is sent as a Playback State too. The ``time`` messages already carry
the bus clock, which a replay sets to the recording's time.
"""

from __future__ import annotations

import asyncio
import logging

from ...bus.errors import ServiceError
from ...bus.topics import Message
from ...protocol import foxglove as fg
from ...protocol import foxglove_playback as pb
from .context import FoxgloveContext

log = logging.getLogger(__name__)

STATE_TOPIC = "/replay/state"
SEEK = "/replay/seek"
MAX_PENDING = 16
"""Requests one client may have in progress (a timeline scrubbed fast sends many)."""


class PlaybackOps:
    """One client's playback control; inert on a server that does not replay."""

    def __init__(self, ctx: FoxgloveContext):
        self.ctx = ctx
        self.active = ctx.bus.service(SEEK) is not None
        self.state: dict | None = None  # the replay's latest /replay/state
        self.tasks: set[asyncio.Task] = set()
        self._applying = 0  # requests being applied: their own answer says what changed
        self._key = (ctx.node, "playback")
        if self.active:
            topic = ctx.bus.topic(STATE_TOPIC)
            self.state = topic.last.msg if topic is not None and topic.last is not None else None
            ctx.bus.subscribe(STATE_TOPIC, None, self._key, ctx.node, self._changed,
                              replay_latched=False)

    def describe(self, info: dict) -> dict:
        """``serverInfo`` with the capability and the data's range, when replaying."""
        if self.active and self.state is not None:
            info["capabilities"] = [*info["capabilities"], pb.CAPABILITY]
            start = fg.nanoseconds(self.state["start"])
            info.update(pb.data_range(start, start + fg.nanoseconds(self.state["duration"])))
        return info

    # ------------------------------------------------------------------ requests
    def request(self, data: bytes) -> None:
        """A Playback Control Request frame (binary op 3)."""
        if not self.active:
            raise fg.FoxgloveError("playback control request: this server is not replaying a "
                                   "recording (no 'playbackControl' capability)")
        request = pb.parse_request(data)
        if len(self.tasks) >= MAX_PENDING:
            raise fg.FoxgloveError(f"playback control request: {MAX_PENDING} requests are in "
                                   "progress; wait for their playback state")
        task = asyncio.ensure_future(self._apply(request))
        self.tasks.add(task)
        task.add_done_callback(self.tasks.discard)

    async def _apply(self, request: pb.PlaybackRequest) -> None:
        bus, state = self.ctx.bus, self.state or {}
        self._applying += 1
        try:
            if request.speed != state.get("speed"):
                await bus.call_service("/replay/set_speed", {"speed": request.speed})
            if request.seek_ns is not None:
                position = request.seek_ns / 1e9 - state.get("start", 0.0)
                position = min(max(position, 0.0), state.get("duration", 0.0))
                await bus.call_service(SEEK, {"position": position})
            await bus.call_service("/replay/resume" if request.play else "/replay/pause", {})
        except ServiceError as exc:
            self.ctx.out.status(fg.ERROR, f"playback control request: {exc}")
        finally:
            self._applying -= 1
        self._send(request.seek_ns is not None, request.request_id)

    # ------------------------------------------------------------------ state
    def _changed(self, message: Message) -> None:
        """A new /replay/state: tell the client when what it shows changed (status, speed);
        the position it follows by the ``time`` messages."""
        before, self.state = self.state, message.msg
        if self._applying:
            return
        if before is None or _status(before) != _status(message.msg) or (
                before["speed"] != message.msg["speed"]):
            self._send(False, "")

    def _send(self, did_seek: bool, request_id: str) -> None:
        state = self.state
        if state is None or self.ctx.out.outbox.closed:
            return
        current = fg.nanoseconds(state["start"] + state["position"])
        self.ctx.out.binary(pb.playback_state(_status(state), current, state["speed"], did_seek,
                                              request_id))

    def close(self) -> None:
        for task in self.tasks:
            task.cancel()
        if self.active:
            self.ctx.bus.unsubscribe(STATE_TOPIC, self._key)


def _status(state: dict) -> int:
    if not state["paused"]:
        return pb.PLAYING
    return pb.ENDED if state["position"] >= state["duration"] else pb.PAUSED

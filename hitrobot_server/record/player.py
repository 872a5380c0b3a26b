"""Replaying a recording onto the bus: every recorded topic, in order, with its recorded
contents and stamps, paced by the recorded log times; latched channels stay latched (the map
reaches late joiners). Controlled by ``/replay/pause``, ``/replay/resume``, ``/replay/seek`` and
``/replay/set_speed``; ``/replay/state`` (latched) says where it is. It starts paused until a
client subscribes to a replayed topic (or ``play=True``), so nobody misses the beginning; its
position is the bus clock (:meth:`Player.clock`), so clients see the recording's time.

Reading the file (what it holds, what it may inflate) is :mod:`.reading`.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time

from ..bus.cdr import Ros2Codec
from ..bus.core import Bus
from ..bus.errors import BusError, ServiceError
from ..bus.names import CLIENT_NODE_PREFIX
from .reading import Entry, Recording

log = logging.getLogger(__name__)

NODE = "/replay"
STATE_TOPIC = "/replay/state"
STATE_PERIOD = 0.25
MAX_SPEED = 100.0


class Player:
    """Serves a :class:`Recording` on the bus from :meth:`start` to :meth:`stop`."""

    def __init__(self, bus: Bus, recording: Recording, *, speed: float = 1.0,
                 loop: bool = False, start: float = 0.0, play: bool = False):
        if not (math.isfinite(speed) and 0 < speed <= MAX_SPEED):
            raise ValueError(f"--speed must be above 0 and at most {MAX_SPEED:g}")
        if not (math.isfinite(start) and 0 <= start <= recording.duration):
            raise ValueError(f"--start must be between 0 and {recording.duration:.3f} s")
        self.bus = bus
        self.recording = recording
        self.codec = Ros2Codec(bus.types)
        self.speed = speed
        self.loop = loop
        self.paused = not play
        self.waiting = not play  # paused until a client subscribes to a replayed topic
        self._cursor = iter(())  # the messages from the position on, read as they come
        self._next: Entry | None = None  # the one due next; None: the end
        self._played = 0
        self._origin = start  # recording seconds at wall time _wall
        self._wall = time.monotonic()
        self._start = start
        self._changed = asyncio.Event()
        self._tasks: list[asyncio.Task] = []
        self._skipped: set[int] = set()  # channels whose topic the bus refused
        self._topics = {track.topic for track in recording.tracks.values()}

    # ------------------------------------------------------------------ position
    @property
    def position(self) -> float:
        if self.paused:
            return self._origin
        moved = self._origin + (time.monotonic() - self._wall) * self.speed
        return min(moved, self.recording.duration)

    def clock(self) -> float:
        """The recording's time now (UNIX seconds): the replaying server's clock."""
        return self.recording.start_ns / 1e9 + self.position

    def _set_clock(self, position: float) -> None:
        """``position`` is now; the next message stays the one due next."""
        self._origin = position
        self._wall = time.monotonic()
        self._changed.set()

    # ------------------------------------------------------------------ lifecycle
    async def start(self) -> None:
        bus = self.bus
        bus.register_node(NODE)
        for channel, track in list(self.recording.tracks.items()):
            try:
                bus.advertise(track.topic, track.mtype.name, self, NODE, latch=track.latched)
            except BusError as exc:  # this server already has the topic with another type
                log.warning("replay: %s is not replayed: %s", track.topic, exc)
                self._skipped.add(channel)
        bus.advertise(STATE_TOPIC, "hitrobot_msgs/ReplayState", self, NODE, latch=True)
        bus.advertise_service("/replay/pause", "std_srvs/Trigger", self, NODE, self._pause)
        bus.advertise_service("/replay/resume", "std_srvs/Trigger", self, NODE, self._resume)
        bus.advertise_service("/replay/seek", "hitrobot_msgs/ReplaySeek", self, NODE, self._seek)
        bus.advertise_service("/replay/set_speed", "hitrobot_msgs/ReplaySetSpeed", self, NODE,
                              self._set_speed)
        self._seek_to(self._start)
        self._tasks = [asyncio.ensure_future(self._play()), asyncio.ensure_future(self._report())]
        bus.watchers.append(self._bus_changed)
        if self.waiting:
            log.info("replay: %s paused at %.3f s until a client subscribes to one of its %d "
                     "topics (--play starts at once)", self.recording.path.name, self._origin,
                     len(self._topics))

    def _bus_changed(self, kind: str, name: str) -> None:
        """The first client subscribing to a replayed topic starts a waiting replay."""
        if not self.waiting or kind != "topic" or name not in self._topics:
            return
        topic = self.bus.topic(name)
        if topic is None or not any(node.startswith(CLIENT_NODE_PREFIX)
                                    for node, _cb in list(topic.subscribers.values())):
            return
        log.info("replay: a client subscribed to %s: playing", name)
        self.waiting = False
        self.paused = False
        self._set_clock(self._origin)
        self._publish_state()

    async def stop(self) -> None:
        if self._bus_changed in self.bus.watchers:
            self.bus.watchers.remove(self._bus_changed)
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self.bus.remove_owner(self)
        self.bus.unregister_node(NODE)

    # ------------------------------------------------------------------ playing
    def _publish(self, entry: Entry) -> None:
        channel, log_time, data = entry
        if channel in self._skipped:
            return
        track = self.recording.tracks[channel]
        try:
            msg = self.codec.decode(data, track.mtype)
        except Exception as exc:  # checked schemas, but the bytes may still be bad
            log.warning("replay: a %s message at %.3f s cannot be decoded (%s)", track.topic,
                        self.recording.seconds(log_time), exc)
            return
        self.bus.publish(track.topic, msg, stamp=log_time / 1e9)

    def _seek_to(self, position: float) -> None:
        """Jump to ``position``; latched topics get their latest message before it (the map
        as it was then), so what a subscriber holds matches the new position."""
        self._cursor = self.recording.cursor(position)  # (lets the chunks held before go)
        self._next = None
        self._set_clock(position)
        for entry in self.recording.latched_before(position):
            self._publish(entry)
        self._next = next(self._cursor, None)
        self._publish_state()

    async def _play(self) -> None:
        while True:
            self._changed.clear()
            if self._next is None:
                if self.loop and self.recording.duration > 0:  # (a single instant: once)
                    self._seek_to(0.0)
                    continue
                if not self.paused:
                    self._origin, self.paused = self.recording.duration, True
                    self._publish_state()
                await self._changed.wait()
                continue
            if self.paused:
                await self._changed.wait()
                continue
            delay = (self.recording.seconds(self._next[1]) - self._origin) / self.speed - (
                time.monotonic() - self._wall)
            if delay > 0:
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._changed.wait(), delay)
                continue
            self._publish(self._next)
            self._next = next(self._cursor, None)
            self._played += 1
            if self._played % 64 == 0:
                await asyncio.sleep(0)  # a burst (after a stall) still lets clients in

    async def _report(self) -> None:
        while True:
            await asyncio.sleep(STATE_PERIOD)
            if not self.paused:
                self._publish_state()

    def _publish_state(self) -> None:
        self.bus.publish(STATE_TOPIC, {
            "file": self.recording.path.name,
            "position": self.position,
            "duration": self.recording.duration,
            "speed": self.speed,
            "paused": self.paused,
            "loop": self.loop,
            "start": self.recording.start_ns / 1e9,
            "waiting": self.waiting,
        })

    # ------------------------------------------------------------------ services
    async def _pause(self, _request: dict) -> dict:
        if not self.paused:
            self._origin, self.paused = self.position, True
            self._changed.set()
            self._publish_state()
        return {"success": True, "message": f"paused at {self._origin:.3f} s"}

    async def _resume(self, _request: dict) -> dict:
        self.waiting = False
        if self.paused:
            self.paused = False
            if self._next is None:  # ended: from the start again
                self._seek_to(0.0)
            else:
                self._set_clock(self._origin)
                self._publish_state()
        return {"success": True, "message": f"playing from {self._origin:.3f} s"}

    async def _seek(self, request: dict) -> dict:
        position = request.get("position")
        duration = self.recording.duration
        if not isinstance(position, int | float) or not (
                math.isfinite(position) and 0 <= position <= duration):
            raise ServiceError(f"field 'position' must be between 0 and {duration:.3f} s, "
                               f"got {position!r}")
        self._seek_to(float(position))
        return {"success": True, "message": f"at {position:.3f} s"}

    async def _set_speed(self, request: dict) -> dict:
        speed = request.get("speed")
        if not isinstance(speed, int | float) or not (
                math.isfinite(speed) and 0 < speed <= MAX_SPEED):
            raise ServiceError(f"field 'speed' must be above 0 and at most {MAX_SPEED:g}, "
                               f"got {speed!r}")
        if not self.paused:
            self._origin, self._wall = self.position, time.monotonic()
        self.speed = float(speed)
        self._changed.set()
        self._publish_state()
        return {"success": True, "message": f"speed {speed:g}"}

"""Replaying a recording onto the bus: every recorded topic, in order, with its recorded
contents and stamps, paced by the recorded log times; latched channels stay latched (the map
reaches late joiners). Controlled by ``/replay/pause``, ``/replay/resume``, ``/replay/seek`` and
``/replay/set_speed``; ``/replay/state`` (latched) says where it is.

A file is checked completely before anything is served: an MCAP file with its footer (a
recording cut short is refused as truncated), ROS 2 channels (``cdr`` messages, ``ros2msg``
schemas) of types we know, each schema describing the same fields as our definition of it.
"""

from __future__ import annotations

import asyncio
import bisect
import contextlib
import logging
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

from mcap.exceptions import EndOfFile
from mcap.records import Channel, Footer, Message, Schema
from mcap.stream_reader import StreamReader
from rosbags.typesys import get_types_from_msg

from ..bus.cdr import Ros2Codec
from ..bus.core import Bus
from ..bus.errors import BusError, ServiceError
from ..types.registry import MsgType, TypeRegistry, UnknownType
from .profile import AUDIT_TOPIC, is_latched

log = logging.getLogger(__name__)

NODE = "/replay"
STATE_TOPIC = "/replay/state"
STATE_PERIOD = 0.25
MAX_SPEED = 100.0
MAGIC = b"\x89MCAP0\r\n"
# the audit trail, and the state of a recorder or player at the time: the replaying server
# has its own
NOT_REPLAYED = frozenset({AUDIT_TOPIC, STATE_TOPIC, "/record/state"})


class RecordingError(ValueError):
    """A file that cannot be replayed; the text says why."""


@dataclass(frozen=True, slots=True)
class Track:
    topic: str
    mtype: MsgType
    latched: bool


@dataclass
class Recording:
    """A checked recording: its tracks and messages (log time order), raw CDR."""

    path: Path
    tracks: dict[int, Track]
    times: list[float]  # seconds from the first message
    messages: list[tuple[int, int, bytes]]  # (channel id, log time ns, CDR)

    @property
    def duration(self) -> float:
        return self.times[-1] if self.times else 0.0


def _check_schema(codec: Ros2Codec, schema: Schema, channel: Channel, mtype: MsgType) -> None:
    try:
        found = get_types_from_msg(schema.data.decode(), schema.name)
    except Exception as exc:
        raise RecordingError(
            f"channel {channel.topic}: its schema {schema.name} cannot be parsed ({exc})"
        ) from None
    codec.type_hash(mtype.name)  # registers our types in the ROS 2 store
    for name, (_consts, fields) in found.items():
        ours = codec.store.fielddefs.get(name)
        if ours is None or ours[1] != fields:
            raise RecordingError(
                f"channel {channel.topic}: the recording's {name} is not ours (alien schema: "
                "its fields differ from our definition)"
            )


def load_recording(path: Path | str, types: TypeRegistry) -> Recording:
    """Read and check a whole recording (blocking; run it in a thread)."""
    path = Path(path)
    try:
        file = open(path, "rb")  # noqa: SIM115 - closed below
    except OSError as exc:
        raise RecordingError(f"cannot open {path}: {exc.strerror or exc}") from None
    codec = Ros2Codec(types)
    schemas: dict[int, Schema] = {}
    tracks: dict[int, Track] = {}
    skipped: set[int] = set()
    messages: list[tuple[int, int, bytes]] = []
    complete = False
    with file:
        if file.read(len(MAGIC)) != MAGIC:
            raise RecordingError(f"{path} is not an MCAP file")
        file.seek(0)
        try:
            for record in StreamReader(file, skip_magic=False).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    if record.id in tracks or record.id in skipped:
                        continue
                    if record.topic in NOT_REPLAYED:
                        skipped.add(record.id)
                        continue
                    tracks[record.id] = _track(codec, types, record, schemas.get(record.schema_id))
                elif isinstance(record, Message) and record.channel_id in tracks:
                    messages.append((record.channel_id, record.log_time, record.data))
                elif isinstance(record, Footer):
                    complete = True
        except RecordingError:
            raise
        except Exception as exc:
            if isinstance(exc, EndOfFile) or file.tell() >= os.fstat(file.fileno()).st_size:
                raise RecordingError(f"{path} is truncated: it ends in the middle of a record "
                                     "(a recording that was cut off)") from None
            raise RecordingError(
                f"{path} is corrupt ({type(exc).__name__}: {exc or 'bad record'})") from None
    if not complete:
        raise RecordingError(f"{path} is truncated: it ends before the MCAP footer (a "
                             "recording that was cut off)")
    if not messages:
        raise RecordingError(f"{path} has no ROS 2 messages to replay")
    messages.sort(key=lambda m: m[1])
    first = messages[0][1]
    return Recording(path, tracks, [(m[1] - first) / 1e9 for m in messages], messages)


def _track(codec: Ros2Codec, types: TypeRegistry, channel: Channel,
           schema: Schema | None) -> Track:
    if schema is None or schema.encoding != "ros2msg" or channel.message_encoding != "cdr":
        found = f"{schema.encoding if schema else 'no'} schema, {channel.message_encoding}"
        raise RecordingError(f"channel {channel.topic} is not ROS 2 ({found}; alien schema: "
                             "replay needs ros2msg schemas and cdr messages)")
    try:
        mtype = types.msg(schema.name)
    except UnknownType:
        raise RecordingError(
            f"channel {channel.topic} has a type we do not know: {schema.name} (alien schema)"
        ) from None
    _check_schema(codec, schema, channel, mtype)
    return Track(channel.topic, mtype, is_latched(dict(channel.metadata)))


class Player:
    """Serves a :class:`Recording` on the bus from :meth:`start` to :meth:`stop`."""

    def __init__(self, bus: Bus, recording: Recording, *, speed: float = 1.0,
                 loop: bool = False, start: float = 0.0):
        if not (math.isfinite(speed) and 0 < speed <= MAX_SPEED):
            raise ValueError(f"--speed must be above 0 and at most {MAX_SPEED:g}")
        if not (math.isfinite(start) and 0 <= start <= recording.duration):
            raise ValueError(f"--start must be between 0 and {recording.duration:.3f} s")
        self.bus = bus
        self.recording = recording
        self.codec = Ros2Codec(bus.types)
        self.speed = speed
        self.loop = loop
        self.paused = False
        self._index = 0
        self._origin = start  # recording seconds at wall time _wall
        self._wall = time.monotonic()
        self._start = start
        self._changed = asyncio.Event()
        self._tasks: list[asyncio.Task] = []
        self._skipped: set[int] = set()  # channels whose topic the bus refused

    # ------------------------------------------------------------------ position
    @property
    def position(self) -> float:
        if self.paused:
            return self._origin
        moved = self._origin + (time.monotonic() - self._wall) * self.speed
        return min(moved, self.recording.duration)

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

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self.bus.remove_owner(self)
        self.bus.unregister_node(NODE)

    # ------------------------------------------------------------------ playing
    def _publish(self, index: int) -> None:
        channel, log_time, data = self.recording.messages[index]
        if channel in self._skipped:
            return
        track = self.recording.tracks[channel]
        try:
            msg = self.codec.decode(data, track.mtype)
        except Exception as exc:  # checked schemas, but the bytes may still be bad
            log.warning("replay: a %s message at %.3f s cannot be decoded (%s)", track.topic,
                        self.recording.times[index], exc)
            return
        self.bus.publish(track.topic, msg, stamp=log_time / 1e9)

    def _seek_to(self, position: float) -> None:
        """Jump to ``position``; latched topics get their latest message before it (the map
        as it was then), so what a subscriber holds matches the new position."""
        self._index = bisect.bisect_left(self.recording.times, position)
        self._set_clock(position)
        latest: dict[int, int] = {}
        for i in range(self._index):
            channel = self.recording.messages[i][0]
            if self.recording.tracks[channel].latched:
                latest[channel] = i
        for i in sorted(latest.values()):
            self._publish(i)
        self._publish_state()

    async def _play(self) -> None:
        times = self.recording.times
        while True:
            self._changed.clear()
            if self._index >= len(times):
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
            delay = (times[self._index] - self._origin) / self.speed - (
                time.monotonic() - self._wall)
            if delay > 0:
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._changed.wait(), delay)
                continue
            self._publish(self._index)
            self._index += 1
            if self._index % 64 == 0:
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
        })

    # ------------------------------------------------------------------ services
    async def _pause(self, _request: dict) -> dict:
        if not self.paused:
            self._origin, self.paused = self.position, True
            self._changed.set()
            self._publish_state()
        return {"success": True, "message": f"paused at {self._origin:.3f} s"}

    async def _resume(self, _request: dict) -> dict:
        if self.paused:
            self.paused = False
            if self._index >= len(self.recording.times):  # ended: from the start again
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

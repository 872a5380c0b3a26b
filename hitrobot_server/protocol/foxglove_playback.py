"""The Foxglove protocol's ``playbackControl`` capability, sans I/O: the client's Playback Control
Request (binary op 3) and the server's Playback State (binary op 5), little-endian as the spec
lays them out; the data range announced in ``serverInfo``."""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

from .foxglove import FoxgloveError

CAPABILITY = "playbackControl"
CLIENT_PLAYBACK_CONTROL_REQUEST = 3
SERVER_PLAYBACK_STATE = 5
PLAY, PAUSE = 0, 1  # the request's playback command
PLAYING, PAUSED, BUFFERING, ENDED = 0, 1, 2, 3  # the state's status
MAX_REQUEST_ID = 256
"""Longest request id accepted (the client's own label, echoed back)."""

_REQUEST = struct.Struct("<BBfBQI")  # opcode, command, speed, had seek, seek time, id length
_STATE = struct.Struct("<BBQfBI")  # opcode, status, current time, speed, did seek, id length


@dataclass(frozen=True, slots=True)
class PlaybackRequest:
    """What the timeline asks for: play or pause, at a speed, maybe from a time (ns)."""

    play: bool
    speed: float
    seek_ns: int | None
    request_id: str


def parse_request(data: bytes) -> PlaybackRequest:
    """A Playback Control Request frame; a malformed one raises FoxgloveError naming the field."""
    if len(data) < _REQUEST.size:
        raise FoxgloveError(f"playback control request: {len(data)} bytes, shorter than its "
                            f"header ({_REQUEST.size})")
    _op, command, speed, had_seek, seek_ns, length = _REQUEST.unpack_from(data)
    if command not in (PLAY, PAUSE):
        raise FoxgloveError(f"playback control request: field 'playbackCommand' {command} is "
                            "neither play (0) nor pause (1)")
    if not (math.isfinite(speed) and speed > 0):
        raise FoxgloveError(f"playback control request: field 'playbackSpeed' {speed} is not "
                            "above 0")
    if length > MAX_REQUEST_ID or _REQUEST.size + length != len(data):
        raise FoxgloveError(f"playback control request: field 'requestId' length {length} "
                            f"does not match the frame (at most {MAX_REQUEST_ID})")
    try:
        request_id = bytes(data[_REQUEST.size:]).decode("utf-8")
    except UnicodeDecodeError:
        raise FoxgloveError("playback control request: field 'requestId' is not UTF-8") from None
    return PlaybackRequest(command == PLAY, speed, seek_ns if had_seek else None, request_id)


def playback_state(status: int, current_ns: int, speed: float, did_seek: bool,
                   request_id: str = "") -> bytes:
    """A Playback State frame (``request_id`` empty when no request caused it)."""
    rid = request_id.encode()
    return _STATE.pack(SERVER_PLAYBACK_STATE, status, current_ns, speed, did_seek,
                       len(rid)) + rid


def request_frame(play: bool, speed: float, seek_ns: int | None, request_id: str) -> bytes:
    """A Playback Control Request as a client sends it (for clients and tests)."""
    rid = request_id.encode()
    return _REQUEST.pack(CLIENT_PLAYBACK_CONTROL_REQUEST, PLAY if play else PAUSE, speed,
                         seek_ns is not None, seek_ns or 0, len(rid)) + rid


def parse_state(data: bytes) -> tuple[int, int, float, bool, str]:
    """A Playback State frame: status, current time (ns), speed, did seek, request id."""
    _op, status, current, speed, did_seek, length = _STATE.unpack_from(data)
    return status, current, speed, bool(did_seek), bytes(data[_STATE.size:
                                                             _STATE.size + length]).decode()


def data_range(start_ns: int, end_ns: int) -> dict:
    """``dataStartTime``/``dataEndTime`` of ``serverInfo`` ({sec, nsec} each)."""
    return {"dataStartTime": {"sec": start_ns // 10**9, "nsec": start_ns % 10**9},
            "dataEndTime": {"sec": end_ns // 10**9, "nsec": end_ns % 10**9}}

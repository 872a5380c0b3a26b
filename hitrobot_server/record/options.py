"""What the recorder needs to know of the server's settings; each field's ``help`` (metadata)
makes its flag and TOML key, its default is the server's."""

from __future__ import annotations

import re
from dataclasses import dataclass, field

_SIZE = re.compile(r"(\d+(?:\.\d+)?)\s*([KMGT]?)(?:i?B)?", re.IGNORECASE)
_TIME = re.compile(r"(\d+(?:\.\d+)?)\s*([smhd]?)", re.IGNORECASE)
_SIZE_UNITS = {"": 1, "k": 1024, "m": 1024**2, "g": 1024**3, "t": 1024**4}
_TIME_UNITS = {"": 1, "s": 1, "m": 60, "h": 3600, "d": 86400}


def parse_size(text: str) -> int:
    """Bytes of ``500M``, ``2G``, ``1.5GiB``, ``4096`` (K/M/G/T are powers of 1024)."""
    found = _SIZE.fullmatch(text.strip())
    if found is None:
        raise ValueError(f"{text!r} is not a size (e.g. 500M, 2G)")
    return int(float(found[1]) * _SIZE_UNITS[found[2].lower()])


def parse_duration(text: str) -> float:
    """Seconds of ``90``, ``90s``, ``10m``, ``2h``, ``1d``."""
    found = _TIME.fullmatch(text.strip())
    if found is None:
        raise ValueError(f"{text!r} is not a duration (e.g. 600, 10m, 1h)")
    return float(found[1]) * _TIME_UNITS[found[2].lower()]


@dataclass(frozen=True)
class RecordOptions:
    record: str | None = field(default=None, metadata={
        "help": "record every bus message into this MCAP file (ROS 2 profile: CDR messages, "
        "ros2msg schemas, zstd chunks) while serving, with an audit channel of client ops"})
    record_topics: str | None = field(default=None, metadata={
        "help": "comma-separated fnmatch patterns of topics to record (default: all)"})
    record_split_size: int = field(default=0, metadata={
        "help": "start a new file (NAME_1.mcap, ...) when a recording reaches this many MiB "
        "(0 = never)"})
    record_split_time: str | None = field(default=None, metadata={
        "help": "start a new file when a recording's file spans this long (seconds, or e.g. "
        "10m, 1h)"})
    record_max_disk: str | None = field(default=None, metadata={
        "help": "keep the recordings under this size (e.g. 500M, 2G): the oldest files are "
        "removed first, never the one being written"})

    black_box: float = field(default=0.0, metadata={
        "help": "keep the last SECONDS of the recorded topics in memory (0 = off): "
        "/record/snapshot writes them to the recordings folder, and so does an incident "
        "(robot link lost, a goal aborted, localization lost, an emergency stop, shutdown)"})
    black_box_max_mb: int = field(default=64, metadata={
        "help": "the black box holds at most this many MiB (the oldest messages go first)"})
    black_box_localization: int = field(default=30, metadata={
        "help": "a localization quality under this (0-100) is a black-box incident "
        "(0 = never)"})

    @property
    def black_box_bytes(self) -> int:
        return self.black_box_max_mb * 1024 * 1024

    @property
    def split_bytes(self) -> int:
        return self.record_split_size * 1024 * 1024

    @property
    def split_seconds(self) -> float:
        return parse_duration(self.record_split_time) if self.record_split_time else 0.0

    @property
    def max_disk_bytes(self) -> int:
        return parse_size(self.record_max_disk) if self.record_max_disk else 0

    def check(self) -> None:
        if self.record_split_size < 0:
            raise ValueError("record_split_size must be 0 or more (MiB)")
        try:
            seconds, budget = self.split_seconds, self.max_disk_bytes
        except ValueError as exc:
            raise ValueError(f"record: {exc}") from None
        if self.record_split_time and seconds < 1:
            raise ValueError("record_split_time must be at least 1 second")
        if self.record_max_disk and budget < 1024 * 1024:
            raise ValueError("record_max_disk must be at least 1M")
        if self.black_box < 0:
            raise ValueError("black_box must be 0 or more (seconds)")
        if self.black_box_max_mb < 1:
            raise ValueError("black_box_max_mb must be 1 or more (MiB)")
        if not 0 <= self.black_box_localization <= 100:
            raise ValueError("black_box_localization must be 0 to 100")

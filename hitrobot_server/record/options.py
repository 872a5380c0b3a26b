"""What the recorder needs to know of the server's settings; each field's ``help`` (metadata)
makes its flag and TOML key, its default is the server's."""

from __future__ import annotations

from dataclasses import dataclass, field


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

    def check(self) -> None:
        if self.record_split_size < 0:
            raise ValueError("record_split_size must be 0 or more (MiB)")
        if self.black_box < 0:
            raise ValueError("black_box must be 0 or more (seconds)")
        if self.black_box_max_mb < 1:
            raise ValueError("black_box_max_mb must be 1 or more (MiB)")
        if not 0 <= self.black_box_localization <= 100:
            raise ValueError("black_box_localization must be 0 to 100")

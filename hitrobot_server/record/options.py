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

    @property
    def split_bytes(self) -> int:
        return self.record_split_size * 1024 * 1024

    def check(self) -> None:
        if self.record_split_size < 0:
            raise ValueError("record_split_size must be 0 or more (MiB)")

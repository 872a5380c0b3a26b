"""Where the site's memory is kept on disk: map folders, the robots' state folders and the
recordings, each a setting whose ``help`` (metadata) makes its flag and TOML key."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .location import default_root, user_data


@dataclass(frozen=True)
class StoreOptions:
    map_dir: str | None = field(default=None, metadata={
        "help": "folder of saved map folders (default: $XDG_DATA_HOME/hitrobot-server/maps)"})
    state_dir: str | None = field(default=None, metadata={
        "help": "folder of the robots' working state, one sub-folder per robot identity, "
        "written on every change and restored at start (default: "
        "$XDG_STATE_HOME/hitrobot-server)"})
    fresh: bool = field(default=False, metadata={
        "help": "start with a clean state: the robot's state folder is set aside, not read"})
    record_dir: str | None = field(default=None, metadata={
        "help": "folder of /record/start's recordings, downloadable at /recordings/NAME "
        "(default: $XDG_DATA_HOME/hitrobot-server/recordings)"})

    @property
    def map_store(self) -> Path:
        """Where map folders are saved: ``--map-dir`` or the per-user data directory."""
        return Path(self.map_dir) if self.map_dir else user_data("maps")

    @property
    def state_root(self) -> Path:
        """Where robots' state folders are (one per robot identity): ``--state-dir`` or
        ``$XDG_STATE_HOME/hitrobot-server``."""
        return Path(self.state_dir) if self.state_dir else default_root()

    @property
    def recordings(self) -> Path:
        """Where ``/record/start`` writes and HTTP serves recordings from: ``--record-dir``
        or the per-user data directory."""
        return Path(self.record_dir) if self.record_dir else user_data("recordings")

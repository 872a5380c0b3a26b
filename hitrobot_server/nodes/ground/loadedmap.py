"""Which saved map is loaded, and the default files a map folder may hold.

The map-files node owns both; the route and graph nodes see them through :class:`MapDefaults`,
so none of them imports the map-files node.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Protocol

GRAPH_FILE = "graph.yaml"
ROUTE_FILE = "route.yaml"
DEFAULT_MAP_NAME = "map"


class LoadedMap:
    """Which saved map is loaded (None until one is)."""

    def __init__(self) -> None:
        self.name: str | None = None

    @property
    def frame(self) -> str:
        """The map frame name: the loaded map's name, or ``map``."""
        return self.name or DEFAULT_MAP_NAME


class MapDefaults(Protocol):
    """A loaded map's default files: who applies them on load, and where they are saved."""

    loaded: LoadedMap
    defaults: dict[str, Callable[[bytes], str]]
    """Default-file name → applier; an applier returns what it did and raises
    :class:`~.namedfiles.FileError` when the file is bad."""

    def save_default(self, filename: str, data: bytes) -> Path | None:
        """Write a default file into the loaded map's folder (None if no map is loaded)."""
        ...

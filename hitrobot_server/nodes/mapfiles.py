"""Map files as the hitrobot SDK sees them: ``list_map_files``, ``load_laser_map``, ``set_map``.

The maps are the map manager's map folders (``--map-dir``); nothing here reads or writes a map
itself. ``load_laser_map`` publishes the map manager's own ``/map_manager/load_map`` request and
answers with its outcome, so a map loads exactly as it does from the map manager (robot map,
walls, tracks, home, masks, POIs). A map folder may also hold the map's **default graph**
(``graph.yaml``) and **default route** (``route.yaml``): they are written there when a graph or a
route file is saved while that map is loaded, and loading the map (through either service) makes
them the current graph and route, as the SDK's ``loadMap()`` does.

This module also holds :class:`NamedFiles`, the folder of ``<name>.yaml`` files the route and
graph stores use (names validated by the map store's own rule, atomic writes), and
:class:`LoadedMap`, which map is loaded (its name is the map frame name of waypoints and of
the ``/{map_name}/{robot_id}/Odometry`` topic).
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Callable
from pathlib import Path

import yaml

from ..bus.core import Bus
from ..bus.topics import Message, RequestRejected
from ..config import Settings
from ..robot.backend import BackendError, NotConnectedError, RobotBackend
from .base import RobotNode
from .map_manager.node import NODE_NAME as MAP_MANAGER
from .map_manager.store import MapStore, StoreError, validate_name, write_file
from .messages import pose2d_of

log = logging.getLogger(__name__)

PKG = "hitrobot_msgs"
LOAD_MAP_TOPIC = f"{MAP_MANAGER}/load_map"
LOADED_PREFIX = "load_map: loaded map"
GRAPH_FILE = "graph.yaml"
ROUTE_FILE = "route.yaml"
DEFAULT_MAP_NAME = "map"
LOAD_TIMEOUT = 60.0
SUFFIX = ".yaml"


class FileError(ValueError):
    """A refused file name or an unreadable file; the text is user-facing."""


def check_name(name: str) -> str:
    """A file name validated by the map store's rule (plain name, no path, ≤ 64 chars)."""
    try:
        return validate_name(name)
    except StoreError as exc:
        raise FileError(str(exc).replace("map folder name", "file name")) from None


class NamedFiles:
    """A folder of ``<name>.yaml`` files; names never leave the folder."""

    def __init__(self, root: Path | str):
        self.root = Path(root)

    def path(self, name: str) -> Path:
        check_name(name)
        root = self.root.resolve()
        path = (root / f"{name}{SUFFIX}").resolve()
        if path.parent != root:
            raise FileError(f"file name {name!r} leaves the store")
        return path

    def names(self) -> list[str]:
        if not self.root.is_dir():
            return []
        return sorted(p.name[: -len(SUFFIX)] for p in self.root.iterdir()
                      if p.is_file() and p.name.endswith(SUFFIX) and not p.name.startswith("."))

    def exists(self, name: str) -> bool:
        return self.path(name).is_file()

    def write(self, name: str, data: bytes) -> Path:
        path = self.path(name)
        try:
            self.root.mkdir(parents=True, exist_ok=True)
            write_file(path, data)
        except OSError as exc:
            raise FileError(f"cannot write {path}: {exc.strerror or exc}") from None
        return path

    def read(self, name: str) -> bytes:
        try:
            return self.path(name).read_bytes()
        except FileNotFoundError:
            raise FileError(f"File not found: {name}") from None
        except OSError as exc:
            raise FileError(f"cannot read {name!r}: {exc.strerror or exc}") from None


def is_default_dir(root: Path, directory: str) -> bool:
    """``directory`` names the store folder ``root``: empty (the default) or its own path."""
    if not directory.strip():
        return True
    try:
        return Path(directory).expanduser().resolve() == root.resolve()
    except (OSError, ValueError):
        return False


def list_reply(root: Path, directory: str, names: Callable[[], list[str]]) -> dict:
    """The answer of a ``list_*_files`` service: only the store's own folder is listed."""
    if not is_default_dir(root, directory):
        return {"success": False, "files": [],
                "message": f"only the default directory can be listed ({root}); "
                           "give an empty directory"}
    try:
        files = names()
    except OSError as exc:
        return {"success": False, "files": [], "message": f"cannot list {root}: {exc}"}
    return {"success": True, "message": f"Found {len(files)} files", "files": files}


def dump_yaml(kind: str, doc: dict) -> bytes:
    head = f"# hitrobot-server {kind}\n"
    return (head + yaml.safe_dump({"version": 1, **doc}, sort_keys=False)).encode()


def load_yaml(data: bytes, what: str) -> dict:
    try:
        doc = yaml.safe_load(data.decode("utf-8"))
    except (UnicodeDecodeError, yaml.YAMLError) as exc:
        raise FileError(f"{what} is not valid YAML: {exc}") from None
    if not isinstance(doc, dict) or doc.get("version") != 1:
        raise FileError(f"{what} is not a version 1 hitrobot-server file")
    return doc


def number(value: object, path: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise FileError(f"field '{path}' must be a finite number")
    return float(value)


class LoadedMap:
    """Which saved map is loaded (None until one is); listeners hear every load."""

    def __init__(self) -> None:
        self.name: str | None = None
        self.listeners: list[Callable[[str], None]] = []

    @property
    def frame(self) -> str:
        """The map frame name: the loaded map's name, or ``map``."""
        return self.name or DEFAULT_MAP_NAME


class MapFilesNode(RobotNode):
    """``list_map_files``, ``load_laser_map`` and ``set_map`` over the map manager's store."""

    def __init__(self, bus: Bus, backend: RobotBackend, settings: Settings):
        super().__init__(bus, "/map_files", backend)
        self.backend: RobotBackend = backend
        self.store = MapStore(settings.map_store)
        self.loaded = LoadedMap()
        self.defaults: dict[str, Callable[[bytes], str]] = {}
        """Default-file name → applier (the graph and patrol nodes register theirs); an
        applier returns what it did and raises :class:`FileError` when the file is bad."""
        self.service("/list_map_files", f"{PKG}/ListMapFiles", self._list)
        self.service("/load_laser_map", f"{PKG}/LoadLaserMap", self._load)
        self.service("/set_map", f"{PKG}/SetLaserMap", self._set_map)
        # A client loading a map through the map manager directly loads it for us too.
        self.subscribe(LOAD_MAP_TOPIC, "map_messages/SaveMap", self._on_manager_load)

    # ------------------------------------------------------------------ services
    async def _list(self, request: dict) -> dict:
        return list_reply(self.store.root, request["directory"], self.store.names)

    async def _load(self, request: dict) -> dict:
        name = request["name"]
        try:
            exists = self.store.exists(name)
        except StoreError as exc:
            return {"success": False, "message": f"Invalid map name: {exc}"}
        if not exists:
            return {"success": False, "message": "Map not found"}
        topic = self.bus.topic(LOAD_MAP_TOPIC)
        if topic is None or not any(key != (self, LOAD_MAP_TOPIC) for key in topic.subscribers):
            return {"success": False, "message": "the map manager is not running"}
        if not self.backend.connected:
            return {"success": False, "message": "the robot is not connected"}
        loop = asyncio.get_running_loop()
        outcome: asyncio.Future[tuple[str, str]] = loop.create_future()

        def reply(level: str, text: str) -> None:
            if not outcome.done():
                outcome.set_result((level, text))

        self.advertise(LOAD_MAP_TOPIC, "map_messages/SaveMap")
        self.bus.publish(LOAD_MAP_TOPIC, {"filename": name}, reply=reply)
        try:
            level, text = await asyncio.wait_for(outcome, LOAD_TIMEOUT)
        except TimeoutError:
            return {"success": False, "message": "the map manager did not answer"}
        if level != "info":
            return {"success": False, "message": text}
        notes = self._loaded(name)
        return {"success": True, "message": " ".join(["Map loaded.", *notes])}

    async def _set_map(self, request: dict) -> dict:
        name = request["name"]
        if name.lstrip("/") not in {self.loaded.frame, ""}:
            return {"success": False,
                    "message": f"map {name!r} is not loaded (the loaded map is "
                               f"{self.loaded.frame!r}); load it with load_laser_map first"}
        try:
            pose = pose2d_of(request["initial_pose"], "initial_pose")
        except RequestRejected as exc:
            return {"success": False, "message": str(exc)}
        try:
            await self.backend.set_pose(pose)
        except NotConnectedError:
            return {"success": False, "message": "the robot is not connected"}
        except BackendError as exc:
            return {"success": False, "message": f"setting the initial pose failed: {exc}"}
        return {"success": True, "message": "Map saved."}  # sic: the seed's success text

    # ------------------------------------------------------------------ loads
    def _on_manager_load(self, message: Message) -> None:
        """Notice a client's successful ``/map_manager/load_map`` from the manager's reply."""
        if message.origin is None:
            return  # ours (load_laser_map handles its own outcome) or another node's
        name = message.msg["filename"]
        original = message.reply

        def reply(level: str, text: str) -> None:
            if level == "info" and text.startswith(LOADED_PREFIX):
                self._loaded(name)
            if original is not None:
                original(level, text)

        message.reply = reply

    def _loaded(self, name: str) -> list[str]:
        """A map was loaded: remember it and apply its default graph and route."""
        self.loaded.name = name
        for listener in list(self.loaded.listeners):
            listener(name)
        notes = []
        for filename, apply in self.defaults.items():
            try:
                if not self.store.has_file(name, filename):
                    continue
                text = apply(self.store.read(name, filename))
            except (StoreError, FileError) as exc:
                notes.append(f"Its {filename} was not applied: {exc}.")
                log.warning("map %s: %s not applied: %s", name, filename, exc)
            else:
                log.info("map %s: %s", name, text)
        return notes

    def save_default(self, filename: str, data: bytes) -> Path | None:
        """Write a default graph/route into the loaded map's folder (None if no map is)."""
        name = self.loaded.name
        if name is None:
            return None
        try:
            folder = self.store.folder(name)
            if not folder.is_dir():
                return None
            path = folder / filename
            write_file(path, data)
        except (StoreError, OSError) as exc:
            log.warning("map %s: cannot write its %s: %s", name, filename, exc)
            return None
        return path

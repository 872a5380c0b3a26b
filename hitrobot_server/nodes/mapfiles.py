"""Map files as the hitrobot SDK sees them: ``list_map_files``, ``load_laser_map``, ``set_map``.

The maps are the map manager's map folders (``--map-dir``); nothing here reads or writes a map
itself. ``load_laser_map`` publishes the map manager's own ``/map_manager/load_map`` request and
answers with its outcome, so a map loads exactly as it does from the map manager (robot map,
walls, tracks, home, masks, POIs). A map folder may also hold the map's **default graph**
(``graph.yaml``) and **default route** (``route.yaml``): they are written there when a graph or a
route file is saved while that map is loaded, and loading the map (through either service) makes
them the current graph and route, as the SDK's ``loadMap()`` does.

Which map is loaded (:class:`~.ground.loadedmap.LoadedMap`; its name is the map frame name of
waypoints and of the ``/{map_name}/{robot_id}/Odometry`` topic) is kept here, and handed to the
route, graph and locomotion nodes by the assembly.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from pathlib import Path

from ..bus.core import Bus
from ..bus.topics import Message, RequestRejected
from ..robot.backend import BackendError, Link, LocalizationBackend
from .base import RobotNode
from .ground.loadedmap import LoadedMap
from .ground.mapstore import MapStore, StoreError, write_file
from .ground.messages import pose2d_of
from .ground.namedfiles import FileError, list_reply
from .ground.names import MAP_MANAGER_LOAD_MAP, MAP_MANAGER_LOADED_MAP
from .ground.requests import NOT_CONNECTED, robot_error
from .options import NodeOptions

log = logging.getLogger(__name__)

PKG = "hitrobot_msgs"
LOAD_MAP_TOPIC = MAP_MANAGER_LOAD_MAP
LOADED_PREFIX = "load_map: loaded map"
LOAD_TIMEOUT = 60.0


class MapFilesNode(RobotNode):
    """``list_map_files``, ``load_laser_map`` and ``set_map`` over the map manager's store;
    the route and graph nodes see it as their :class:`~.ground.loadedmap.MapDefaults`."""

    GLOBAL_NAMES = ("/map_files", "/list_map_files", "/load_laser_map", "/set_map")

    def __init__(self, bus: Bus, link: Link, localization: LocalizationBackend,
                 settings: NodeOptions):
        super().__init__(bus, "/map_files", link)
        self.localization = localization
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
        # Which map is loaded, as the map manager keeps it (latched: after a restart too).
        self.subscribe(MAP_MANAGER_LOADED_MAP, "std_msgs/String", self._on_loaded_map)

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
        if not self.link.connected:
            return {"success": False, "message": NOT_CONNECTED}
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
            await self.localization.set_pose(pose)
        except BackendError as exc:
            return {"success": False,
                    "message": robot_error(exc, "setting the initial pose failed")}
        return {"success": True, "message": "Map saved."}  # sic: the seed's success text

    # ------------------------------------------------------------------ loads
    def _on_manager_load(self, message: Message) -> None:
        """Notice a client's successful ``/map_manager/load_map`` from the manager's reply."""
        if message.origin is None:
            return  # ours (load_laser_map handles its own outcome) or another node's
        name = message.msg["filename"]

        def loaded(level: str, text: str) -> None:
            if level == "info" and text.startswith(LOADED_PREFIX):
                self._loaded(name)

        message.reply.observe(loaded)

    def _on_loaded_map(self, message: Message) -> None:
        self.loaded.name = message.msg["data"] or None

    def _loaded(self, name: str) -> list[str]:
        """A map was loaded: remember it and apply its default graph and route."""
        self.loaded.name = name
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

"""``save_map`` and ``load_map``: the map folders of the map store (:mod:`.mapio` says what is
in one). Saving writes the robot's map, the masks, the POIs and the robot's walls, tracks and
dock; loading checks the whole folder before anything is applied. Which map was loaded last is
kept in the state folder and on the latched ``loaded_map`` topic (the console's "· loaded")."""

from __future__ import annotations

import asyncio

from ...bus.topics import Message, RequestRejected
from ...robot.backend import BackendError
from ...robot.model import ArtifactUsage
from ..base import RobotNode
from ..ground.mapstore import MapStore, StoreError
from ..ground.memory import NotSaved
from ..ground.names import (
    MAP_MANAGER_LOAD_MAP,
    MAP_MANAGER_SAVE_MAP,
    SLAMWARE_CLEAR_MAP,
    SLAMWARE_MAP_CLEARED,
)
from . import mapio
from .composition import MapComposition
from .jobs import job
from .layers import Grid, Mask
from .poi_requests import PoiRequests
from .pois import PoiRegistry
from .robot_map import RobotMap
from .sections import Sections
from .topics import LOADED_TOPIC, PKG

Folder = tuple[Grid, dict[int, Mask], PoiRegistry, dict | None]
"""A map folder's map, masks, POIs and robot artifacts (walls, tracks, dock; None: none)."""


class MapFolders:
    """Saves the site's map into a folder of the store, and loads one back."""

    def __init__(self, node: RobotNode, store: MapStore, robot_map: RobotMap,
                 layers: MapComposition, pois: PoiRequests, sections: Sections):
        self.node, self.store, self.robot_map = node, store, robot_map
        self.layers, self.pois, self.sections = layers, pois, sections
        node.advertise(LOADED_TOPIC, "std_msgs/String", latch=True)

    def publish_loaded(self) -> None:
        self.node.publish(LOADED_TOPIC, {"data": self.sections.loaded})

    def listen(self) -> None:
        self.node.subscribe(MAP_MANAGER_SAVE_MAP, f"{PKG}/SaveMap", self._on_save_map)
        self.node.subscribe(MAP_MANAGER_LOAD_MAP, f"{PKG}/SaveMap", self._on_load_map)
        self.node.subscribe(SLAMWARE_CLEAR_MAP, "slamware_ros_sdk/ClearMapRequest",
                            self._on_clear_map, passive=True)

    def _on_clear_map(self, message: Message) -> None:
        """The robot's map cleared (the Slamware node's answer says so): no saved map is loaded
        any more, and the console's "· loaded" goes."""

        def cleared(level: str, text: str) -> None:
            if level == "info" and text.endswith(SLAMWARE_MAP_CLEARED) and self.sections.loaded:
                self.sections.loaded = ""
                self.sections.remember("loaded")
                self.publish_loaded()

        message.reply.observe(cleared)

    def clean_leftovers(self) -> list[str]:
        """At start-up, before anything can save: what interrupted saves left behind."""
        return self.store.clean_leftovers()

    def _folder(self, what: str, message: Message) -> str:
        name = message.msg["filename"]
        try:
            self.store.folder(name)
        except StoreError as exc:
            raise RequestRejected(f"{what}: {exc}") from None
        return name

    def _on_save_map(self, message: Message) -> None:
        name = self._folder("save_map", message)
        masks = {layer: Mask.from_cells(mask.resolution, mask.col0, mask.row0, mask.cells)
                 for layer, mask in self.layers.masks.items()}
        pois = self.pois.pois.all()

        async def work() -> str:
            async with self.robot_map.io_lock:
                grid = await self.robot_map.read()
                if grid is None:
                    raise BackendError("the robot has no map to save yet")
                b = self.robot_map.maps
                robot = mapio.encode_robot(await b.get_lines(ArtifactUsage.VIRTUAL_WALL),
                                           await b.get_lines(ArtifactUsage.VIRTUAL_TRACK),
                                           await b.get_home_pose())

                def write():
                    map_yaml, map_pgm = mapio.encode_map(grid)
                    files = {mapio.MAP_YAML: map_yaml, mapio.MAP_IMAGE: map_pgm,
                             **mapio.encode_masks(masks),
                             mapio.POIS_YAML: mapio.encode_pois(pois),
                             mapio.ROBOT_YAML: robot}
                    return self.store.save(name, files)

                path = await asyncio.to_thread(write)
            return f"saved map {name!r} to {path}"

        job(self.node, message, "save_map", work)

    def _on_load_map(self, message: Message) -> None:
        name = self._folder("load_map", message)

        async def work() -> str:
            async with self.robot_map.io_lock:
                grid, masks, pois, robot = await asyncio.to_thread(self._read_folder, name)
                await self.robot_map.install(grid, robot)
                self.layers.masks = masks
                self.pois.pois.replace_all(pois.all())
                self.sections.loaded = name
                self.sections.remember("pois", "masks", "loaded")
                self.pois.publish()
                self.layers.publish_map(force=True)
                self.publish_loaded()
                try:
                    await self.layers.push_blocked()
                except BackendError as exc:
                    raise BackendError(f"map {name!r} loaded, but the robot did not take its "
                                       f"blocked areas ({exc}); retrying") from None
                await self._saved(name)
            return f"loaded map {name!r}"

        job(self.node, message, "load_map", work)

    async def _saved(self, name: str) -> None:
        """The load's sections on disk, or its POIs, masks and marker taken back (the robot
        keeps the map it was given) and the load answered with the reason."""
        try:
            await self.sections.kept("load_map")
        except NotSaved as exc:
            self.sections.take_back()
            self.pois.publish()
            self.layers.publish_map(force=True)
            self.publish_loaded()
            raise NotSaved(f"{exc}: the POIs, masks and marker of map {name!r} were taken "
                           "back (the robot has its map)") from None

    def _read_folder(self, name: str) -> Folder:
        """Everything of a map folder, parsed and validated before anything is applied."""
        s = self.store
        map_yaml = s.read(name, mapio.MAP_YAML)
        grid = mapio.decode_map(map_yaml, s.read(name, mapio.map_image_name(map_yaml)))
        masks: dict[int, Mask] = {}
        if s.has_file(name, mapio.MASKS_YAML):
            masks_yaml = s.read(name, mapio.MASKS_YAML)
            images = {image: s.read(name, image) for image in mapio.mask_images(masks_yaml)}
            masks = mapio.decode_masks(masks_yaml, images)
        pois = PoiRegistry()
        if s.has_file(name, mapio.POIS_YAML):
            pois.replace_all(mapio.decode_pois(s.read(name, mapio.POIS_YAML)))
        robot = None
        if s.has_file(name, mapio.ROBOT_YAML):
            robot = mapio.decode_robot(s.read(name, mapio.ROBOT_YAML))
        return grid, masks, pois, robot

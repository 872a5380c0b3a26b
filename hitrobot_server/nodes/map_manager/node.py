"""``/map_manager``: POIs, map layers and masks, the composed ``/map``, and map folders.

Requests arrive on topics (``map_messages``); a request that is refused changes nothing and
its publisher gets a ``status`` error saying why. Work that needs the robot or the disk runs in
the background and reports failures (and, at status level ``info``, success) the same way.

The node is the wiring of its parts, one module each: the POIs (:mod:`.poi_requests`), the
layer switches and masks (:mod:`.mask_requests`), the composed ``/map`` and the blocked areas
handed to the robot (:mod:`.composition`), the robot's own map (:mod:`.robot_map`), the map
folders (:mod:`.folders`) and the node's sections of the state folder (:mod:`.sections`).
"""

from __future__ import annotations

import logging

from ...bus.core import Bus
from ...robot.backend import Link, LocalizationBackend, MapBackend
from ...state import StateBinding
from ..base import RobotNode
from ..ground.mapstore import MapStore
from ..ground.memory import NodeMemory
from ..options import NodeOptions
from .composition import MapComposition
from .folders import MapFolders
from .mask_requests import MaskRequests
from .poi_requests import PoiRequests
from .pois import PoiRegistry
from .robot_map import RobotMap
from .sections import Sections
from .topics import MAP_TOPIC, NODE_NAME

log = logging.getLogger(__name__)

MEMORY = "map_manager"
"""Its sections' prefix in a state folder (``map_manager/pois``, ``…/layers``, ``…/masks``,
``…/loaded``)."""


class MapManager(RobotNode):
    """The map manager node; needs a robot (the SLAM layer is the robot's map)."""

    GLOBAL_NAMES = (NODE_NAME, MAP_TOPIC)

    def __init__(self, bus: Bus, link: Link, maps: MapBackend,
                 localization: LocalizationBackend, settings: NodeOptions,
                 state: StateBinding | None = None):
        super().__init__(bus, NODE_NAME, link)
        params = settings.slamware
        self.pois = PoiRegistry()
        self.layers = MapComposition(self, maps, params)
        self.sections = Sections(NodeMemory(state, MEMORY), self.pois, self.layers)
        self.poi_requests = PoiRequests(self, self.pois, self.sections,
                                        lambda: self.layers.published)
        self.robot_map = RobotMap(self, maps, localization, params)
        self.mask_requests = MaskRequests(self, self.layers, self.sections)
        self.folders = MapFolders(self, MapStore(settings.map_store), self.robot_map,
                                  self.layers, self.poi_requests, self.sections)
        self.poi_requests.listen()
        self.folders.listen()
        self.mask_requests.listen()
        self.robot_map.listen()
        self.layers.listen()
        self.poi_requests.serve()
        self.sections.restore()
        self.poi_requests.publish()
        self.folders.publish_loaded()

    def adopt(self, restore: bool) -> None:
        """A state folder was bound (a REST robot said who it is): take its sections
        (``restore``) or write ours into it (ours are newer)."""
        if not restore:
            self.sections.remember("pois", "layers", "masks", "loaded")
            return
        self.sections.restore()
        self.poi_requests.publish()
        self.folders.publish_loaded()
        self.layers.resend_blocked()

    def restored(self) -> list[str]:
        return self.sections.restored()

    async def start(self) -> None:
        removed = self.folders.clean_leftovers()  # at start-up, before anything can save
        if removed:
            log.info("map store: removed leftovers of interrupted saves: %s", ", ".join(removed))
        self.layers.start()
        self.robot_map.start()

    async def stop(self) -> None:
        self.layers.stop()
        await super().stop()

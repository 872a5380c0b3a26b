"""The Slamware node's copy of the robot's explore map: read whole (in tiles) when a sync is
asked for, then kept current near the robot, published as the node's ``map`` and
``map_metadata``. A cleared map is published as unknown cells over the old extent, and that
extent is kept in the state folder, so a restart publishes the same unknown grid (a late
subscriber never waits for a map that will not come)."""

from __future__ import annotations

from ...robot.capabilities import Robot
from ...robot.model import MapKind, Pose2D, Rect
from ..base import RobotNode
from ..ground import messages as m
from ..ground.mapsync import MapHolder, tiles, window
from ..ground.memory import NodeMemory
from ..ground.slamware_params import SlamwareParams
from .topics import SlamwareTopics

CLEARED = "cleared_map"
"""Section: the extent of a cleared map (published as unknown cells)."""


class MapCopy:
    """The map holder and when it must be read whole again (``sync_requested``)."""

    def __init__(self, node: RobotNode, robot: Robot, params: SlamwareParams,
                 topics: SlamwareTopics, memory: NodeMemory | None = None):
        self.node, self.robot, self.params, self.topics = node, robot, params, topics
        self.memory = memory or NodeMemory(None, "slamware")
        self.map = MapHolder()
        self.sync_requested = True
        self.last_pose: Pose2D | None = None  # the pose publisher's latest, when there is one

    def forget_robot(self) -> None:
        """A (re)connected robot: probe its resolution and read its whole map again."""
        self.sync_requested = True
        self.map.resolution = None

    async def update(self) -> None:
        b = self.robot
        if self.map.resolution is None:
            probe = await b.maps.get_map(Rect(-0.5, -0.5, 1.0, 1.0), MapKind.EXPLORERMAP)
            self.map.reset(probe.resolution)
            self.sync_requested = True
        known = await b.maps.get_known_area(MapKind.EXPLORERMAP)
        if self.sync_requested:
            await self._sync(known)
            return
        if known.is_empty:
            self.sync_requested = True
            return
        pose = self.last_pose or await b.localization.get_pose()
        half = max(2.0, self.params.map_update_near_robot_half_wh)
        area = window(known, pose.x, pose.y, half)
        if area is None:
            return
        region = await b.maps.get_map(area, MapKind.EXPLORERMAP)
        if not self.map.merge(region):
            self.map.resolution = None

    async def cleared(self) -> None:
        """The robot's map was cleared: unknown cells over the old extent from now on, that
        extent kept in the state folder (NotSaved when it could not be)."""
        extent = self.map.extent()
        if extent is not None:
            self.map.forget()
            self.memory.put(CLEARED, extent)
            await self.memory.durable()
        self.sync_requested = True

    async def _sync(self, known: Rect) -> None:
        if known.is_empty:  # cleared: publish unknown cells instead of the old map
            saved = self.memory.get(CLEARED)
            if self.map.empty and isinstance(saved, dict):
                self.map.unknown_over(saved)
            self.map.forget()
            return
        if self.memory.get(CLEARED) is not None:  # a map again: nothing cleared to remember
            self.memory.put(CLEARED, None)
        self.map.clear()
        size = max(16.0, self.params.map_sync_once_get_max_wh)
        for tile in tiles(known, size):
            region = await self.robot.maps.get_map(tile, MapKind.EXPLORERMAP)
            if not self.map.merge(region):
                self.map.resolution = None
                return
        self.sync_requested = False

    async def publish(self) -> None:
        if self.map.resolution is None or self.map.empty:
            return
        data, ox, oy = self.map.occupancy()
        h, w = self.map.cells.shape
        now = self.node.bus.clock()
        info = {
            "map_load_time": m.stamp(now),
            "resolution": self.map.resolution,
            "width": w,
            "height": h,
            "origin": m.pose(Pose2D(ox, oy, 0.0)),
        }
        self.node.publish(self.topics.map, {"header": m.header(self.params.map_frame, now),
                                            "info": info, "data": data})
        self.node.publish(self.topics.map_info, info)

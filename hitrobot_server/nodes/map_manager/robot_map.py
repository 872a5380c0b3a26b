"""The robot's own map as the map manager handles it: read whole (tile by tile, as the
Slamware node does), replaced (by a client's OccupancyGrid on ``/map``, seed 4.3.5, or a loaded
folder), its mapping switched on and off, its dock published on the latched ``home`` topic."""

from __future__ import annotations

import asyncio

from ...bus.topics import Message, RequestRejected
from ...robot.backend import BackendError, LocalizationBackend, MapBackend
from ...robot.model import ArtifactUsage, Line, Point2D, Pose2D, Rect
from ..base import RobotNode
from ..ground import messages as m
from ..ground.mapsync import MapHolder, tiles
from ..ground.names import SLAMWARE_SYNC_MAP
from ..ground.slamware_params import SlamwareParams
from .grids import grid_of_message, to_explore
from .jobs import job
from .layers import Grid, LayerError
from .topics import HOME_TOPIC, MAP_TOPIC, PKG, request_topic

HOME_PERIOD = 2.0
"""How often (s) the home dock's pose is read from the robot; it is published when it changes."""


def _lines(items: list) -> tuple[Line, ...]:
    return tuple(Line(i, Point2D(x0, y0), Point2D(x1, y1)) for i, x0, y0, x1, y1 in items)


class RobotMap:
    """Reads and replaces the robot's map; ``io_lock`` keeps one reader or writer at a time."""

    def __init__(self, node: RobotNode, maps: MapBackend, localization: LocalizationBackend,
                 params: SlamwareParams):
        self.node, self.maps, self.localization, self.params = node, maps, localization, params
        self.io_lock = asyncio.Lock()
        self._home: Pose2D | None | bool = False  # False: not published yet
        node.advertise(HOME_TOPIC, "geometry_msgs/PoseStamped", latch=True)
        node.advertise(SLAMWARE_SYNC_MAP, "slamware_ros_sdk/SyncMapRequest")

    def listen(self) -> None:
        self.node.subscribe(request_topic("do_mapping"), f"{PKG}/DoMapping", self._on_do_mapping)
        self.node.subscribe(MAP_TOPIC, "nav_msgs/OccupancyGrid", self._on_client_map,
                            passive=True)  # a client's map to load: it asks for no polling

    def start(self) -> None:
        self.node.every(HOME_PERIOD, self._publish_home)

    async def _publish_home(self) -> None:
        """The dock on the latched ``home`` topic (consoles draw it), on change; a map without
        a dock publishes an empty frame id."""
        home = await self.maps.get_home_pose()
        if home == self._home:
            return
        self._home = home
        frame = self.params.map_frame
        self.node.publish(HOME_TOPIC, m.pose_stamped(home or Pose2D(0.0, 0.0, 0.0),
                                                     frame if home is not None else ""))

    def _on_client_map(self, message: Message) -> None:
        """A client's OccupancyGrid on /map replaces the robot's map; ours are ignored."""
        if message.origin is None:
            return
        try:
            grid = grid_of_message(message.msg)
        except LayerError as exc:
            raise RequestRejected(f"/map: {exc}") from None

        async def work() -> str:
            async with self.io_lock:
                await self.install(grid)
            return "the robot's map was replaced"

        job(self.node, message, "/map", work)

    def _on_do_mapping(self, message: Message) -> None:
        state = bool(message.msg["state"])

        async def work() -> str:
            await self.maps.set_map_update(state)
            return "mapping on" if state else "mapping off"

        job(self.node, message, "do_mapping", work)

    async def install(self, grid: Grid, robot: dict | None = None) -> None:
        """Load an occupancy grid into the robot as its explore map (keeping its walls, tracks
        and home unless ``robot`` gives them), then have the Slamware node resync."""
        b = self.maps
        probe = await b.get_map(Rect(-0.5, -0.5, 1.0, 1.0))
        region = to_explore(grid, probe.resolution)
        if robot is None:
            walls = tuple(await b.get_lines(ArtifactUsage.VIRTUAL_WALL))
            tracks = tuple(await b.get_lines(ArtifactUsage.VIRTUAL_TRACK))
            home = await b.get_home_pose()
        else:
            walls, tracks = _lines(robot["virtual_walls"]), _lines(robot["virtual_tracks"])
            home = None if robot["home"] is None else Pose2D(*robot["home"])
        await b.install_map(region, walls, tracks, home, await self.localization.get_pose())
        if self.node.bus.topic(SLAMWARE_SYNC_MAP) is not None:
            self.node.publish(SLAMWARE_SYNC_MAP, {})

    async def read(self) -> Grid | None:
        """The robot's whole explore map, fetched in tiles as the Slamware node does."""
        b = self.maps
        known = await b.get_known_area()
        if known.is_empty:
            return None
        holder = MapHolder()
        size = max(16.0, self.params.map_sync_once_get_max_wh)
        for tile in tiles(known, size):
            region = await b.get_map(tile)
            if holder.resolution is None:
                holder.reset(region.resolution)
            if not holder.merge(region):
                raise BackendError("the robot's map changed resolution while being read")
        if holder.empty:
            return None
        data, ox, oy = holder.occupancy()
        h, w = holder.cells.shape
        return Grid(ox, oy, holder.resolution, data.reshape(h, w))

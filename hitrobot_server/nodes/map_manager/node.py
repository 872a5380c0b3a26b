"""``/map_manager``: POIs, map layers and masks, the composed ``/map``, and map folders.

Requests arrive on topics (``map_messages``); a request that is refused changes nothing and
its publisher gets a ``status`` error saying why. Work that needs the robot or the disk runs in
the background and reports failures (and, at status level ``info``, success) the same way.

``/map`` (latched) is the composition of the enabled layers (see :mod:`.layers`). It is
republished at once when a user changes something (a layer toggled, a mask drawn, a map loaded)
and at most twice a second when the robot's map or the obstacle layers change. BLOCKED and
OBSTACLE masks of the enabled layers are handed to the robot as areas its planner must avoid.
A client publishing an OccupancyGrid on ``/map`` replaces the robot's map (seed 4.3.5).
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import logging
import math
from collections.abc import Awaitable, Callable

import numpy as np

from ...bus.core import Bus
from ...bus.topics import Message, RequestRejected
from ...robot.backend import (
    BackendError,
    Link,
    LocalizationBackend,
    MapBackend,
)
from ...robot.model import ArtifactUsage, Line, MapRegion, Point2D, Pose2D, Rect
from ...state import StateBinding
from ..base import RobotNode
from ..ground import messages as m
from ..ground.mapstore import MapStore, StoreError
from ..ground.mapsync import MapHolder, tiles
from ..ground.memory import NodeMemory
from ..ground.names import MAP_MANAGER
from ..ground.requests import answer, require_robot
from ..options import NodeOptions
from . import mapio
from .layers import (
    DEFAULT_STATES,
    KINECT_LAYER,
    LAYER_NAMES,
    MASK_ACTIONS,
    SICK_LAYER,
    Grid,
    LayerError,
    Mask,
    blocked_rectangles,
    compose,
    scan_hits,
)
from .pois import PoiError, PoiRegistry

log = logging.getLogger(__name__)

NODE_NAME = MAP_MANAGER
PKG = "map_messages"
MAP_TOPIC = "/map"
MAP_FRAME = "/map"
POIS_TOPIC = f"{NODE_NAME}/pois"
HOME_TOPIC = f"{NODE_NAME}/home"
HOME_PERIOD = 2.0
"""How often (s) the home dock's pose is read from the robot; it is published when it changes."""
PUBLISH_PERIOD = 0.5
"""Automatic ``/map`` republishing (robot map or obstacle layers changed) is at most 2 Hz."""
DEFAULT_RESOLUTION = 0.05
KINECT_FOV = math.radians(57.0)
KINECT_RANGE = (0.5, 4.0)
"""The simulated depth camera (KINECT_LAYER): the lidar's returns within its field of view
(57°, centred on the robot's heading) and range (0.5-4 m), like a Kinect's."""
MAX_CLIENT_MAP_CELLS = 64_000_000
OCCUPIED_FROM, FREE_UP_TO = 65, 25
"""Occupancy to explore map as map_saver thresholds it: >= 65 occupied, 0..25 free."""
EXPLORE_OCCUPIED, EXPLORE_FREE, EXPLORE_UNKNOWN = 128, 127, 0
PENDING_SCANS = 4
RECONNECT_POLL = 0.5
BLOCKED_RETRY = 2.0
"""Seconds between attempts to hand the robot blocked areas it refused or missed."""
REQUEST_ERRORS = (StoreError, mapio.MapFileError, PoiError, LayerError)
"""A request's own errors: the publisher hears their text, as it does a robot error's."""


def to_explore(grid: Grid, resolution: float) -> MapRegion:
    """An occupancy grid as Slamware explore-map cells at ``resolution`` (nearest-neighbour
    resampling when the resolutions differ)."""
    data = grid.data.astype(np.int16)
    cells = np.full(data.shape, EXPLORE_UNKNOWN, dtype=np.uint8)
    cells[(data >= 0) & (data <= FREE_UP_TO)] = EXPLORE_FREE
    cells[data >= OCCUPIED_FROM] = EXPLORE_OCCUPIED
    if math.isclose(grid.resolution, resolution, rel_tol=1e-6):
        return MapRegion(grid.origin_x, grid.origin_y, resolution, cells)
    width = max(1, math.ceil(grid.width * grid.resolution / resolution - 1e-9))
    height = max(1, math.ceil(grid.height * grid.resolution / resolution - 1e-9))
    if width * height > MAX_CLIENT_MAP_CELLS:
        raise LayerError("the map is too large at the robot's resolution")
    cols = np.minimum(((np.arange(width) + 0.5) * resolution / grid.resolution).astype(int),
                      grid.width - 1)
    rows = np.minimum(((np.arange(height) + 0.5) * resolution / grid.resolution).astype(int),
                      grid.height - 1)
    return MapRegion(grid.origin_x, grid.origin_y, resolution, cells[np.ix_(rows, cols)])


def grid_of_message(msg: dict) -> Grid:
    """A nav_msgs/OccupancyGrid dict as a Grid; LayerError when it is inconsistent."""
    info = msg["info"]
    width, height, resolution = info["width"], info["height"], info["resolution"]
    if not (math.isfinite(resolution) and resolution > 0):
        raise LayerError("field 'info.resolution' must be positive")
    if width <= 0 or height <= 0:
        raise LayerError("the map is empty (width or height is 0)")
    if width * height > MAX_CLIENT_MAP_CELLS:
        raise LayerError(f"the map is too large ({width} x {height} cells)")
    origin = info["origin"]
    x, y = origin["position"]["x"], origin["position"]["y"]
    if not (math.isfinite(x) and math.isfinite(y)):
        raise LayerError("field 'info.origin.position' must be finite")
    q = origin["orientation"]
    if not all(math.isfinite(q[k]) for k in "xyzw"):
        raise LayerError("field 'info.origin.orientation' must be finite")
    if abs(m.yaw_of(q)) > 1e-3:
        raise LayerError("rotated maps (an origin with a yaw) are not supported")
    data = np.asarray(msg["data"])
    if data.size != width * height:
        raise LayerError(f"field 'data' has {data.size} cells, not width x height = "
                         f"{width * height}")
    return Grid(float(x), float(y), float(resolution),
                data.astype(np.int8).reshape(height, width))


def encode_masks(masks: dict[int, Mask]) -> bytes:
    """The masks for the state store: one ``.npz`` (no pickles) of cells and placement."""
    arrays: dict[str, np.ndarray] = {}
    for layer, mask in masks.items():
        arrays[f"cells_{layer}"] = mask.cells
        arrays[f"place_{layer}"] = np.array([mask.resolution, mask.col0, mask.row0])
    out = io.BytesIO()
    np.savez(out, **arrays)
    return out.getvalue()


def decode_masks(data: bytes) -> dict[int, Mask]:
    """What :func:`encode_masks` wrote; LayerError (or ValueError) if it is not that."""
    masks: dict[int, Mask] = {}
    with np.load(io.BytesIO(data), allow_pickle=False) as arrays:
        for name in arrays.files:
            if not name.startswith("cells_"):
                continue
            layer = int(name.removeprefix("cells_"))
            if layer not in LAYER_NAMES:
                raise LayerError(f"unknown layer {layer}")
            resolution, col0, row0 = arrays[f"place_{layer}"].tolist()
            masks[layer] = Mask.from_cells(resolution, int(col0), int(row0), arrays[name])
    return masks


class MapManager(RobotNode):
    """The map manager node; needs a robot (the SLAM layer is the robot's map)."""

    def __init__(self, bus: Bus, link: Link, maps: MapBackend,
                 localization: LocalizationBackend, settings: NodeOptions,
                 state: StateBinding | None = None):
        super().__init__(bus, NODE_NAME, link)
        self.maps = maps
        self.localization = localization
        self.memory = NodeMemory(state, "map_manager")
        self.store = MapStore(settings.map_store)
        params = settings.slamware
        self.params = params
        self.pois = PoiRegistry()
        self.states: dict[int, bool] = dict(DEFAULT_STATES)
        self.masks: dict[int, Mask] = {}
        self.slam: Grid | None = None
        self.hits: dict[int, np.ndarray] = {}
        self.published: Grid | None = None
        self._pending_scans: dict[tuple[int, int], dict] = {}
        self._dirty: asyncio.Event | None = None
        self._last_publish = -math.inf
        self._io_lock = asyncio.Lock()
        self._blocked_lock = asyncio.Lock()
        self._blocked_sent: list | None = []
        self._blocked_stale = False

        self.topic_slam = m.slamware_topic(params.map_topic)
        self.topic_scan = m.slamware_topic(params.scan_topic)
        self.topic_sync = f"{m.SLAMWARE_NODE}/sync_map"
        self.advertise(MAP_TOPIC, "nav_msgs/OccupancyGrid", latch=True)
        self.advertise(POIS_TOPIC, f"{PKG}/PointsOfInterest", latch=True)
        self.advertise(HOME_TOPIC, "geometry_msgs/PoseStamped", latch=True)
        self._home: Pose2D | None | bool = False  # False: not published yet
        self.advertise(self.topic_sync, "slamware_ros_sdk/SyncMapRequest")
        requests: list[tuple[str, str, Callable[[Message], None]]] = [
            ("add_poi", "PointOfInterest", self._on_add_poi),
            ("modify_poi", "ModifyPOI", self._on_modify_poi),
            ("delete_poi", "DeletePointOfInterest", self._on_delete_poi),
            ("save_map", "SaveMap", self._on_save_map),
            ("load_map", "SaveMap", self._on_load_map),
            ("map_layers", "MapLayers", self._on_map_layers),
            ("modify_map", "ModifyMap", self._on_modify_map),
            ("do_mapping", "DoMapping", self._on_do_mapping),
        ]
        for topic, type_name, handler in requests:
            self.subscribe(f"{NODE_NAME}/{topic}", f"{PKG}/{type_name}", handler)
        self.subscribe(MAP_TOPIC, "nav_msgs/OccupancyGrid", self._on_client_map)
        self.subscribe(self.topic_slam, "nav_msgs/OccupancyGrid", self._on_slam_map)
        self.subscribe(self.topic_scan, "sensor_msgs/LaserScan", self._on_scan)
        self.subscribe("/tf", "tf2_msgs/TFMessage", self._on_tf)
        self.service(f"{NODE_NAME}/get_pois", f"{PKG}/GetPointsOfInterest", self._get_pois)
        self._restore()
        self._publish_pois()

    def _restore(self) -> None:
        """POIs, layer switches and masks as the state store kept them; a section that does
        not check out is skipped (and kept aside by the store), the others still apply."""
        pois, layers, masks = (self.memory.get(k) for k in ("pois", "layers", "masks"))
        self.pois.replace_all([])
        self.states, self.masks = dict(DEFAULT_STATES), {}
        if pois is not None:
            try:
                if not isinstance(pois, list):
                    raise PoiError("not a list of POIs")
                self.pois.replace_all(pois)
            except PoiError as exc:
                self.memory.reject("pois", str(exc))
        if layers is not None:
            try:
                states = {int(k): v for k, v in layers.items()}
                if not set(states) <= set(LAYER_NAMES) or not all(
                        isinstance(v, bool) for v in states.values()):
                    raise ValueError("unknown layers or non-boolean states")
                self.states.update(states)
            except (AttributeError, ValueError) as exc:
                self.memory.reject("layers", str(exc))
        if masks is not None:
            try:
                self.masks = decode_masks(masks)
            except (LayerError, ValueError, KeyError, OSError) as exc:
                self.memory.reject("masks", str(exc))

    def adopt(self, restore: bool) -> None:
        """A state folder was bound (a REST robot said who it is): take its sections
        (``restore``) or write ours into it (ours are newer)."""
        if not restore:
            self._remember("pois", "layers", "masks")
            return
        self._restore()
        self._publish_pois()
        self._blocked_sent, self._blocked_stale = None, True
        self._changed()

    def restored(self) -> list[str]:
        """What came back from the state folder, for the start-up log."""
        if self.memory.store is None:
            return []
        phrases = [] if not self.pois else [f"{len(self.pois)} POIs"]
        if self.masks:
            phrases.append(f"masks on {len(self.masks)} layers")
        return phrases

    def _remember(self, *what: str) -> None:
        """Put the named sections (pois, layers, masks) into the state store."""
        for name in what:
            if name == "pois":
                self.memory.put("pois", self.pois.all())
            elif name == "layers":
                self.memory.put("layers", {str(k): v for k, v in self.states.items()})
            else:
                self.memory.put("masks", encode_masks(self.masks) if self.masks else None)

    # ------------------------------------------------------------------ lifecycle
    async def start(self) -> None:
        removed = self.store.clean_leftovers()  # at start-up, before anything can save
        if removed:
            log.info("map store: removed leftovers of interrupted saves: %s", ", ".join(removed))
        self._dirty = asyncio.Event()
        self.spawn(self._publisher())
        self.spawn(self._watch_connection())
        self.every(HOME_PERIOD, self._publish_home)

    async def _publish_home(self) -> None:
        """The dock on the latched ``home`` topic (consoles draw it), on change; a map without
        a dock publishes an empty frame id."""
        home = await self.maps.get_home_pose()
        if home == self._home:
            return
        self._home = home
        frame = self.params.map_frame
        self.publish(HOME_TOPIC, m.pose_stamped(home or Pose2D(0.0, 0.0, 0.0),
                                                frame if home is not None else ""))

    def _job(self, message: Message, what: str, work: Callable[[], Awaitable[str | None]],
             needs_robot: bool = True) -> None:
        """Run ``work`` in the background; its failure (or success text) goes to the
        publisher as a status."""
        if needs_robot:
            require_robot(self.link, what)
        self.spawn(answer(message.reply, what, work(), known=REQUEST_ERRORS))

    # ------------------------------------------------------------------ /map
    def _resolution(self) -> float:
        return self.slam.resolution if self.slam is not None else DEFAULT_RESOLUTION

    def compose(self) -> Grid | None:
        return compose(self.slam, self.states, self.masks, self.hits, self._resolution())

    def publish_map(self, force: bool = False) -> None:
        """Compose and publish ``/map``; unchanged pictures are skipped unless ``force``."""
        grid = self.compose()
        if grid is None or (not force and grid.same_as(self.published)):
            return
        now = self.bus.clock()
        self.publish(MAP_TOPIC, m.occupancy_grid(grid, MAP_FRAME, now))
        self.published = grid
        self._last_publish = asyncio.get_running_loop().time()

    def _changed(self) -> None:
        """The robot's map or a visible obstacle layer changed: republish, throttled."""
        if self._dirty is not None:
            self._dirty.set()

    async def _publisher(self) -> None:
        loop = asyncio.get_running_loop()
        assert self._dirty is not None
        while True:
            if self._blocked_stale:  # retry handing over the blocked areas now and then
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._dirty.wait(), BLOCKED_RETRY)
            else:
                await self._dirty.wait()
            delay = self._last_publish + PUBLISH_PERIOD - loop.time()
            if delay > 0:
                await asyncio.sleep(delay)
            self._dirty.clear()
            try:
                self.publish_map()
            except LayerError as exc:
                log.warning("/map: %s", exc)
            if self._blocked_stale and self.link.connected:
                with contextlib.suppress(BackendError):
                    await self.push_blocked()

    async def _watch_connection(self) -> None:
        """A robot that (re)connects has forgotten our blocked areas: hand them over again."""
        was = self.link.connected
        while True:
            await asyncio.sleep(RECONNECT_POLL)
            now = self.link.connected
            if now and not was:
                self._blocked_sent = None
                self._blocked_stale = True
                self._changed()
            was = now

    async def push_blocked(self) -> None:
        """Hand the robot the BLOCKED/OBSTACLE masks of the enabled layers (if they changed)."""
        async with self._blocked_lock:
            rects = blocked_rectangles(self.states, self.masks)
            if rects == self._blocked_sent:
                self._blocked_stale = False
                return
            polygons = [[Point2D(x0, y0), Point2D(x1, y0), Point2D(x1, y1), Point2D(x0, y1)]
                        for x0, y0, x1, y1 in rects]
            try:
                await self.maps.set_blocked_areas(polygons)
            except BackendError:
                self._blocked_stale = True
                raise
            self._blocked_sent = rects
            self._blocked_stale = False

    def _on_slam_map(self, message: Message) -> None:
        try:
            grid = grid_of_message(message.msg)
        except (LayerError, KeyError, TypeError, ValueError) as exc:
            log.debug("ignoring a bad robot map: %s", exc)
            return
        if grid.same_as(self.slam):
            return
        self.slam = grid  # grid_of_message copied the cells
        self._changed()

    def _on_scan(self, message: Message) -> None:
        stamp = message.msg["header"]["stamp"]
        self._pending_scans[(stamp["secs"], stamp["nsecs"])] = message.msg
        while len(self._pending_scans) > PENDING_SCANS:
            del self._pending_scans[next(iter(self._pending_scans))]

    def _on_tf(self, message: Message) -> None:
        """The node publishes map→laser with each scan's pose right after the scan."""
        for t in message.msg["transforms"]:
            if (t["child_frame_id"] != self.params.laser_frame
                    or t["header"]["frame_id"] != self.params.map_frame):
                continue
            stamp = t["header"]["stamp"]
            scan = self._pending_scans.pop((stamp["secs"], stamp["nsecs"]), None)
            if scan is not None:
                tr = t["transform"]
                pose = (tr["translation"]["x"], tr["translation"]["y"], m.yaw_of(tr["rotation"]))
                self._project(scan, pose)

    def _project(self, scan: dict, pose: tuple[float, float, float]) -> None:
        ranges = scan["ranges"]
        if not isinstance(ranges, np.ndarray):  # a client's scan: null stands for inf
            ranges = [math.inf if r is None else r for r in ranges]
        ranges = np.asarray(ranges, dtype=np.float64)
        angles = scan["angle_min"] + np.arange(len(ranges)) * scan["angle_increment"]
        self.hits[SICK_LAYER] = scan_hits(pose, angles, ranges)
        self.hits[KINECT_LAYER] = scan_hits(pose, angles, ranges, fov=KINECT_FOV,
                                            min_range=KINECT_RANGE[0],
                                            max_range=KINECT_RANGE[1])
        if self.states[SICK_LAYER] or self.states[KINECT_LAYER]:
            self._changed()

    def _on_client_map(self, message: Message) -> None:
        """A client's OccupancyGrid on /map replaces the robot's map; ours are ignored."""
        if message.origin is None:
            return
        try:
            grid = grid_of_message(message.msg)
        except LayerError as exc:
            raise RequestRejected(f"/map: {exc}") from None

        async def work() -> str:
            async with self._io_lock:
                await self._install_map(grid)
            return "the robot's map was replaced"

        self._job(message, "/map", work)

    async def _install_map(self, grid: Grid, robot: dict | None = None) -> None:
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
            def lines(items):
                return tuple(Line(i, Point2D(x0, y0), Point2D(x1, y1))
                             for i, x0, y0, x1, y1 in items)

            walls, tracks = lines(robot["virtual_walls"]), lines(robot["virtual_tracks"])
            home = None if robot["home"] is None else Pose2D(*robot["home"])
        await b.install_map(region, walls, tracks, home, await self.localization.get_pose())
        if self.bus.topic(self.topic_sync) is not None:
            self.publish(self.topic_sync, {})

    # ------------------------------------------------------------------ layers and masks
    def _on_map_layers(self, message: Message) -> None:
        layer, state = message.msg["layer"], bool(message.msg["state"])
        if layer not in LAYER_NAMES:
            names = ", ".join(f"{v}={k}" for k, v in LAYER_NAMES.items())
            raise RequestRejected(f"map_layers: field 'layer' must be one of {names}, "
                                  f"got {layer}")
        self.states[layer] = state
        self._remember("layers")
        self.publish_map(force=True)
        text = f"{LAYER_NAMES[layer]} {'on' if state else 'off'}"
        self._job(message, "map_layers", self._push_then(text), needs_robot=False)

    def _on_modify_map(self, message: Message) -> None:
        msg = message.msg
        layer, action = msg["mapLayer"], msg["maskAction"]
        if layer not in LAYER_NAMES:
            names = ", ".join(f"{v}={k}" for k, v in LAYER_NAMES.items())
            raise RequestRejected(f"modify_map: field 'mapLayer' must be one of {names}, "
                                  f"got {layer}")
        if action not in MASK_ACTIONS:
            names = ", ".join(f"{v}={k}" for k, v in MASK_ACTIONS.items())
            raise RequestRejected(f"modify_map: field 'maskAction' must be one of {names}, "
                                  f"got {action}")
        polygon = [(float(p["x"]), float(p["y"])) for p in msg["region"]]
        mask = self.masks.get(layer) or Mask(self._resolution())
        try:
            cells = mask.paint(polygon, action)
        except LayerError as exc:
            raise RequestRejected(f"modify_map: {exc}") from None
        if mask.empty:
            self.masks.pop(layer, None)
        else:
            self.masks[layer] = mask
        self._remember("masks")
        try:
            self.publish_map(force=True)
        except LayerError as exc:
            log.warning("/map: %s", exc)
        text = f"{MASK_ACTIONS[action]} {cells} cells of {LAYER_NAMES[layer]}"
        self._job(message, "modify_map", self._push_then(text), needs_robot=False)

    def _push_then(self, text: str | None) -> Callable[[], Awaitable[str | None]]:
        async def work() -> str | None:
            await self.memory.durable()
            try:
                await self.push_blocked()
            except BackendError as exc:
                raise BackendError(f"the robot did not take the blocked areas ({exc}); "
                                   "retrying") from None
            return text
        return work

    def _on_do_mapping(self, message: Message) -> None:
        state = bool(message.msg["state"])

        async def work() -> str:
            await self.maps.set_map_update(state)
            return "mapping on" if state else "mapping off"

        self._job(message, "do_mapping", work)

    # ------------------------------------------------------------------ POIs
    def _publish_pois(self) -> None:
        self.publish(POIS_TOPIC, {"pois": self.pois.all()})

    def _poi_request(self, message: Message, what: str, change: Callable[[], str]) -> None:
        try:
            text = change()
        except PoiError as exc:
            raise RequestRejected(f"{what}: {exc}") from None
        self._remember("pois")
        self._publish_pois()

        async def acknowledge() -> None:  # once the change is on disk
            await self.memory.durable()
            message.reply.ok(f"{what}: {text}")

        self.spawn(acknowledge())

    def _on_add_poi(self, message: Message) -> None:
        def add() -> str:
            return f"added {self.pois.add(message.msg)['name']!r}"

        self._poi_request(message, "add_poi", add)

    def _on_modify_poi(self, message: Message) -> None:
        msg = message.msg

        def modify() -> str:
            new = self.pois.modify(msg["old_name"], msg["poi"])
            return f"modified {msg['old_name']!r} (now {new['name']!r})"

        self._poi_request(message, "modify_poi", modify)

    def _on_delete_poi(self, message: Message) -> None:
        name = message.msg["name"]

        def delete() -> str:
            self.pois.delete(name)
            return f"deleted {name!r}"

        self._poi_request(message, "delete_poi", delete)

    async def _get_pois(self, request: dict) -> dict:
        return {"poi_list": {"pois": self.pois.all()}}

    # ------------------------------------------------------------------ map folders
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
                 for layer, mask in self.masks.items()}
        pois = self.pois.all()

        async def work() -> str:
            async with self._io_lock:
                grid = await self.robot_map()
                if grid is None:
                    raise BackendError("the robot has no map to save yet")
                b = self.maps
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

        self._job(message, "save_map", work)

    def _on_load_map(self, message: Message) -> None:
        name = self._folder("load_map", message)

        async def work() -> str:
            async with self._io_lock:
                folder = await asyncio.to_thread(self._read_folder, name)
                grid, masks, pois, robot = folder
                await self._install_map(grid, robot)
                self.masks = masks
                self.pois.replace_all(pois.all())
                self._remember("pois", "masks")
                self._publish_pois()
                self.publish_map(force=True)
                try:
                    await self.push_blocked()
                except BackendError as exc:
                    raise BackendError(f"map {name!r} loaded, but the robot did not take its "
                                       f"blocked areas ({exc}); retrying") from None
                await self.memory.durable()
            return f"loaded map {name!r}"

        self._job(message, "load_map", work)

    def _read_folder(self, name: str) -> tuple[Grid, dict[int, Mask], PoiRegistry, dict | None]:
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

    async def robot_map(self) -> Grid | None:
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

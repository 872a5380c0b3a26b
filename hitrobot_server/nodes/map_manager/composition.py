"""The composed ``/map`` (latched): the enabled layers painted in order (see :mod:`.layers`).

It is republished at once when a user changes something (a layer toggled, a mask drawn, a map
loaded) and at most twice a second when the robot's map or the obstacle layers change. BLOCKED
and OBSTACLE masks of the enabled layers are handed to the robot as areas its planner must
avoid, again whenever the robot (re)connects.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math

import numpy as np

from ...bus.topics import Message
from ...robot.backend import BackendError, MapBackend
from ...robot.model import Point2D
from ..base import RobotNode
from ..ground import messages as m
from ..ground.names import TF
from ..ground.slamware_params import SlamwareParams
from .grids import grid_of_message
from .layers import (
    DEFAULT_STATES,
    KINECT_LAYER,
    SICK_LAYER,
    Grid,
    LayerError,
    Mask,
    blocked_rectangles,
    compose,
    scan_hits,
)
from .topics import MAP_FRAME, MAP_TOPIC

log = logging.getLogger(__name__)

PUBLISH_PERIOD = 0.5
"""Automatic ``/map`` republishing (robot map or obstacle layers changed) is at most 2 Hz."""
DEFAULT_RESOLUTION = 0.05
KINECT_FOV = math.radians(57.0)
KINECT_RANGE = (0.5, 4.0)
"""The simulated depth camera (KINECT_LAYER): the lidar's returns within its field of view
(57°, centred on the robot's heading) and range (0.5-4 m), like a Kinect's."""
PENDING_SCANS = 4
RECONNECT_POLL = 0.5
BLOCKED_RETRY = 2.0
"""Seconds between attempts to hand the robot blocked areas it refused or missed."""


class MapComposition:
    """The layers (the robot's map, switches, masks, scan hits) and the ``/map`` made of them;
    the blocked areas the robot was handed."""

    def __init__(self, node: RobotNode, maps: MapBackend, params: SlamwareParams):
        self.node, self.maps, self.params = node, maps, params
        self.states: dict[int, bool] = dict(DEFAULT_STATES)
        self.masks: dict[int, Mask] = {}
        self.slam: Grid | None = None
        self.hits: dict[int, np.ndarray] = {}
        self.published: Grid | None = None
        self._pending_scans: dict[tuple[int, int], dict] = {}
        self._dirty: asyncio.Event | None = None
        self._last_publish = -math.inf
        self._scans_wanted = False
        self._blocked_lock = asyncio.Lock()
        self._blocked_sent: list | None = []
        self._blocked_stale = False
        node.advertise(MAP_TOPIC, "nav_msgs/OccupancyGrid", latch=True)

    def listen(self) -> None:
        """Follow the robot's map, its scans and their poses (the obstacle layers). They are
        heard passively: the robot's map is fetched at its full rate only while someone reads
        it or ``/map``, the scans and poses only while an obstacle layer is on
        (:meth:`_follow_scans`)."""
        node = self.node
        node.subscribe(m.slamware_topic(self.params.map_topic), "nav_msgs/OccupancyGrid",
                       self._on_slam_map, passive=True)
        node.subscribe(self._scan_topic, "sensor_msgs/LaserScan", self._on_scan, passive=True)
        node.subscribe(TF, "tf2_msgs/TFMessage", self._on_tf, passive=True)

    @property
    def _scan_topic(self) -> str:
        return m.slamware_topic(self.params.scan_topic)

    def _follow_scans(self, stopping: bool = False) -> None:
        """An obstacle layer paints the scans: while one is on, they are wanted whole."""
        on = not stopping and bool(self.states.get(SICK_LAYER) or self.states.get(KINECT_LAYER))
        if on != self._scans_wanted:
            self._scans_wanted = on
            demand = self.node.bus.demand
            for name in (self._scan_topic, TF):
                (demand.want if on else demand.unwant)(name, self)

    def stop(self) -> None:
        """The node stops: it wants the scans no more."""
        self._follow_scans(stopping=True)

    def start(self) -> None:
        self._dirty = asyncio.Event()
        self._follow_scans()
        self.node.spawn(self._publisher())
        self.node.spawn(self._watch_connection())

    def resolution(self) -> float:
        return self.slam.resolution if self.slam is not None else DEFAULT_RESOLUTION

    def compose(self) -> Grid | None:
        return compose(self.slam, self.states, self.masks, self.hits, self.resolution())

    def publish_map(self, force: bool = False) -> None:
        """Compose and publish ``/map``; unchanged pictures are skipped unless ``force``."""
        self._follow_scans()
        grid = self.compose()
        if grid is None or (not force and grid.same_as(self.published)):
            return
        now = self.node.bus.clock()
        self.node.publish(MAP_TOPIC, m.occupancy_grid(grid, MAP_FRAME, now))
        self.published = grid
        self._last_publish = asyncio.get_running_loop().time()

    def changed(self) -> None:
        """The robot's map or a visible obstacle layer changed: republish, throttled."""
        if self._dirty is not None:
            self._dirty.set()

    def resend_blocked(self) -> None:
        """The robot forgot (or never had) our blocked areas: hand them over again soon."""
        self._blocked_sent, self._blocked_stale = None, True
        self.changed()

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
            if self._blocked_stale and self.node.link.connected:
                with contextlib.suppress(BackendError):
                    await self.push_blocked()

    async def _watch_connection(self) -> None:
        """A robot that (re)connects has forgotten our blocked areas: hand them over again."""
        link = self.node.link
        was = link.connected
        while True:
            await asyncio.sleep(RECONNECT_POLL)
            now = link.connected
            if now and not was:
                self.resend_blocked()
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
        self.changed()

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
            self.changed()

"""Patrol routes (``planning/*``): the current waypoints, route files, and the patrol itself.

Services (all answer ``success``/``message``; types in ``schemas/hitrobot_msgs/srv``):

* ``planning/set_waypoints`` (SetWaypoints), ``planning/append_waypoint`` (AppendWaypoint),
  ``planning/clear_waypoints`` (std_srvs/Trigger): edit the current route;
* ``planning/save_waypoints_file`` / ``planning/load_waypoints_file`` /
  ``planning/list_waypoints_files``: route files ``<name>.yaml`` in the route store (the
  ``routes`` folder next to the map store); saving while a map is loaded also makes the route
  that map's default (``route.yaml`` in its folder, loaded with the map);
* ``planning/start_patrol`` (Trigger, from waypoint 0), ``planning/resume_patrol`` (from the
  waypoint nearest the robot), ``planning/stop_patrol`` (Trigger).

A patrol drives the robot to each waypoint in turn (``move_to``, waiting for the robot's action)
and starts over after the last one, until stopped. A waypoint the robot cannot reach is skipped
(the patrol stops when none is reachable); anything else that ends the robot's action — another
command replacing it, ``sit_down``, a cancel — stops the patrol, as does a refused command.
``planning/patrol_state`` (latched ``hitrobot_msgs/PatrolState``) reports the route and progress.
A waypoint on an obstacle of ``/map``, or nearer one than the robot's clearance
(``ground/placement.py``), is refused when the route is set or a waypoint appended, and a patrol
whose route has one (a route loaded from a file, a map changed since) is refused at its start,
before the robot moves.

Frames: a waypoint's ``frame`` is the loaded map's name (``map`` when none is loaded, ``map``
is always accepted) or ``odom``; map→odom is the identity on this robot, so both mean the same
coordinates. ``gps`` is refused: the robot has no GPS receiver. The robot is planar: ``z`` and
``use_z`` are kept and returned but not checked.
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Callable, Coroutine, Sequence
from dataclasses import asdict, dataclass
from typing import Any

from ..bus.core import Bus
from ..robot.backend import (
    BackendError,
    Link,
    LocalizationBackend,
    MotionBackend,
    NotConnectedError,
)
from ..robot.model import ActionInfo, ActionResult, Point2D
from ..robot.motion import cancel_if_current, follow
from ..state import StateBinding
from .base import RobotNode
from .ground.claims import MotionClaims
from .ground.loadedmap import ROUTE_FILE, MapDefaults
from .ground.memory import NodeMemory
from .ground.namedfiles import FileError, NamedFiles, dump_yaml, list_reply, load_yaml, number
from .ground.placement import target_problem
from .ground.requests import robot_error
from .options import NodeOptions

log = logging.getLogger(__name__)

NS = "/planning"
PKG = "hitrobot_msgs"
STATE_TOPIC = f"{NS}/patrol_state"
MAX_WAYPOINTS = 256  # waypoint_index is a uint8
ODOM_FRAMES = frozenset({"odom"})


class RouteError(ValueError):
    """A refused waypoint or route; the text is user-facing."""


@dataclass(frozen=True, slots=True)
class Waypoint:
    frame: str
    x: float
    y: float
    z: float = 0.0
    use_z: bool = False


def frame_ok(frame: str, map_frames: frozenset[str]) -> None:
    """Refuse a frame the robot cannot drive in, saying why."""
    bare = frame.strip().lstrip("/")
    if bare.lower() == "gps":
        raise RouteError("frame 'gps' is not supported: the robot has no GPS receiver; give "
                         "waypoints in the map frame or 'odom'")
    if bare not in map_frames and bare not in ODOM_FRAMES:
        names = ", ".join(repr(f) for f in sorted(map_frames | ODOM_FRAMES) if f)
        raise RouteError(f"frame {frame!r} is neither the loaded map nor odom (use {names})")


def waypoint_of(msg: dict, path: str, map_frames: frozenset[str]) -> Waypoint:
    """A validated hitrobot_msgs/Waypoint (a dict from a request or a route file)."""
    if not isinstance(msg, dict):
        raise RouteError(f"{path} must be a mapping")
    frame = msg.get("frame", "")
    if not isinstance(frame, str):
        raise RouteError(f"field '{path}.frame' must be a string")
    try:
        frame_ok(frame, map_frames)
        x = number(msg.get("x"), f"{path}.x")
        y = number(msg.get("y"), f"{path}.y")
        z = number(msg.get("z", 0.0), f"{path}.z")
    except (RouteError, FileError) as exc:
        raise RouteError(f"{path}: {exc}") from None
    return Waypoint(frame, x, y, z, bool(msg.get("use_z", False)))


def waypoints_of(items: Sequence[dict], map_frames: frozenset[str],
                 name: str = "waypoints") -> list[Waypoint]:
    if len(items) > MAX_WAYPOINTS:
        raise RouteError(f"a route has at most {MAX_WAYPOINTS} waypoints, got {len(items)}")
    return [waypoint_of(item, f"{name}[{i}]", map_frames) for i, item in enumerate(items)]


def encode_route(waypoints: Sequence[Waypoint]) -> bytes:
    return dump_yaml("patrol route", {"waypoints": [asdict(w) for w in waypoints]})


def decode_route(data: bytes, map_frames: frozenset[str], what: str = "route file"
                 ) -> list[Waypoint]:
    doc = load_yaml(data, what)
    items = doc.get("waypoints")
    if not isinstance(items, list):
        raise RouteError(f"{what} has no 'waypoints' list")
    return waypoints_of(items, map_frames)


def nearest(waypoints: Sequence[Waypoint], x: float, y: float) -> int:
    """Index of the waypoint closest to (x, y); the first of equals."""
    return min(range(len(waypoints)),
               key=lambda i: math.hypot(waypoints[i].x - x, waypoints[i].y - y))


class Route:
    """The current route, its waypoints and name, kept in the node's section of the state
    folder (not the patrol: a restarted server does not set the robot moving on its own)."""

    def __init__(self, memory: NodeMemory) -> None:
        self.memory = memory
        self.waypoints: list[Waypoint] = []
        self.name = ""

    def restore(self, map_frames: frozenset[str]) -> None:
        """The route as the state folder kept it (none, and the section set aside, when it
        no longer validates)."""
        saved = self.memory.get("route")
        self.waypoints, self.name = [], ""
        if saved is None:
            return
        try:
            self.waypoints = waypoints_of(saved["waypoints"], map_frames)
            self.name = str(saved["route"])
        except (RouteError, KeyError, TypeError) as exc:
            self.memory.reject("route", str(exc))

    def set(self, waypoints: list[Waypoint], name: str) -> None:
        self.waypoints, self.name = waypoints, name
        self.remember()

    def remember(self) -> None:
        self.memory.put("route", {"route": self.name,
                                  "waypoints": [asdict(w) for w in self.waypoints]})

    async def durable(self) -> None:
        """Wait until the route is on disk (NotSaved when it could not be written)."""
        await self.memory.durable()

    def restored(self) -> list[str]:
        """What came back from the state folder, for the start-up log."""
        if self.memory.store is None or not self.waypoints:
            return []
        return [f"1 route ({len(self.waypoints)} waypoints)"]


class Patrol:
    """The patrol itself: the waypoint the robot heads to, the laps, its last word and the
    robot's action it started. It reads ``route`` on every leg (a running patrol picks up an
    appended waypoint), says each change through ``changed`` and runs its loop as a task of
    ``spawn`` (the node's, stopped with it)."""

    def __init__(self, motion: MotionBackend, link: Link,
                 route: Route, changed: Callable[[], None],
                 spawn: Callable[[Coroutine[Any, Any, None]], asyncio.Task],
                 claims: MotionClaims | None = None) -> None:
        self.motion = motion
        self.claims = claims or MotionClaims()  # who took the robot over from the patrol
        self.link = link
        self._route = route
        self._changed = changed
        self._spawn = spawn
        self.active = False
        self.target = -1
        self.laps = 0
        self.text = "idle"
        self._task: asyncio.Task | None = None
        self._action_id: int | None = None

    async def begin(self, index: int) -> str | None:
        """Stop any patrol, send the robot to waypoint ``index`` and patrol from there; the
        reason when the robot refuses."""
        await self.halt("restarted")
        w = self._route.waypoints[index]
        try:
            action = await self.motion.move_to([Point2D(w.x, w.y)])
        except BackendError as exc:
            return robot_error(exc, f"the robot refused waypoint {index}")
        self.active, self.target, self.laps = True, index, 0
        self.text = f"heading to waypoint {index}"
        self._action_id = action.action_id
        self._changed()
        self._task = self._spawn(self._run(index, action))
        return None

    async def halt(self, text: str) -> None:
        """Stop the patrol (if any) and the robot's action if it is still ours."""
        task, self._task = self._task, None
        if task is not None and task is not asyncio.current_task():
            task.cancel()
        if self.active:
            action_id, self._action_id = self._action_id, None
            if self.link.connected:
                await cancel_if_current(self.motion, action_id, "patrol: ")
            self._end(text)

    def _end(self, text: str) -> None:
        self.active, self.target, self.text = False, -1, text
        self._action_id = None
        self._changed()

    async def _run(self, index: int, action: ActionInfo | None) -> None:
        first, failures = index, 0
        try:
            while True:
                waypoints = self._route.waypoints
                if not waypoints:
                    self._end("stopped: the route is empty")
                    return
                index %= len(waypoints)
                w = waypoints[index]
                if action is None:
                    self.target, self.text = index, f"heading to waypoint {index}"
                    self._changed()
                    action = await self.motion.move_to([Point2D(w.x, w.y)])
                    self._action_id = action.action_id
                final = await follow(self.motion, action)
                action = None
                if final is None:
                    self._end("stopped: the robot's action was replaced by another command")
                    return
                if final.result == ActionResult.SUCCESS:
                    failures = 0
                    self.text = f"reached waypoint {index}"
                elif final.result == ActionResult.FAILED:
                    failures += 1
                    self.text = f"skipped waypoint {index}: {final.reason or 'unreachable'}"
                    if failures >= len(self._route.waypoints):
                        self._end(f"stopped: no waypoint is reachable ({final.reason})")
                        return
                else:
                    by = self.claims.taken_by(final.action_id)
                    self._end(f"stopped: taken over by {by}" if by else
                              f"stopped: the robot's action ended ({final.reason or 'aborted'})")
                    return
                index = (index + 1) % len(self._route.waypoints)
                if index == first % len(self._route.waypoints):
                    self.laps += 1
                self._changed()
        except NotConnectedError:
            self._end("stopped: the robot disconnected")
        except BackendError as exc:
            self._end(f"stopped: {exc}")


class PatrolNode(RobotNode):
    """``planning/*``: the services over the current route (:class:`Route`), route files and
    the patrol (:class:`Patrol`)."""

    GLOBAL_NAMES = (NS, "/patrol")

    def __init__(self, bus: Bus, link: Link, motion: MotionBackend,
                 localization: LocalizationBackend, settings: NodeOptions,
                 mapfiles: MapDefaults, state: StateBinding | None = None,
                 claims: MotionClaims | None = None):
        super().__init__(bus, NS, link)
        self.localization = localization
        self.mapfiles = mapfiles
        self.files = NamedFiles(settings.map_store.parent / "routes")
        if removed := self.files.clean_leftovers():  # created at start-up, before any save
            log.info("routes: removed leftovers of interrupted saves: %s", ", ".join(removed))
        self.map_frames_extra = frozenset({"map", settings.slamware.map_frame.lstrip("/")})
        self.route = Route(NodeMemory(state, "patrol"))
        self.patrol = Patrol(motion, link, self.route, self._publish, self.spawn, claims)
        self.advertise(STATE_TOPIC, f"{PKG}/PatrolState", latch=True)
        for name, type_name, handler in [
            ("list_waypoints_files", "ListWaypointsFiles", self._list),
            ("load_waypoints_file", "LoadWaypointsFile", self._load),
            ("save_waypoints_file", "SaveWaypointsFile", self._save),
            ("resume_patrol", "ResumePatrol", self._resume),
            ("set_waypoints", "SetWaypoints", self._set),
            ("append_waypoint", "AppendWaypoint", self._append),
        ]:
            self.service(f"{NS}/{name}", f"{PKG}/{type_name}", handler)
        for name, handler in [("clear_waypoints", self._clear), ("start_patrol", self._start),
                              ("stop_patrol", self._stop)]:
            self.service(f"{NS}/{name}", "std_srvs/Trigger", handler)
        mapfiles.defaults[ROUTE_FILE] = self._apply_default
        self.route.restore(self.map_frames)
        self._publish()

    @property
    def map_frames(self) -> frozenset[str]:
        return self.map_frames_extra | {self.mapfiles.loaded.frame}

    async def stop(self) -> None:
        await self.patrol.halt("stopped")
        await super().stop()

    # ------------------------------------------------------------------ state
    def adopt(self, restore: bool) -> None:
        """A state folder was bound: take its route (``restore``) or write ours into it."""
        if restore:
            self.route.restore(self.map_frames)
            self._publish()
        else:
            self.route.remember()

    def restored(self) -> list[str]:
        """What came back from the state folder, for the start-up log."""
        return self.route.restored()

    def _publish(self) -> None:
        run = self.patrol
        self.publish(STATE_TOPIC, {
            "active": run.active, "route": self.route.name,
            "waypoints": [asdict(w) for w in self.route.waypoints],
            "target_index": run.target, "laps": run.laps, "message": run.text})

    def _misplaced(self, waypoints: Sequence[Waypoint], first: int = 0) -> str | None:
        """Why a waypoint (numbered from ``first``) cannot be sent to: on an obstacle of
        ``/map`` or nearer one than the robot's clearance (ground/placement.py)."""
        for i, w in enumerate(waypoints, first):
            if problem := target_problem(self.bus, f"waypoint {i}", w.x, w.y):
                return problem
        return None

    def _replace(self, waypoints: list[Waypoint], name: str) -> None:
        self.route.set(waypoints, name)
        self._publish()

    # ------------------------------------------------------------------ route services
    async def _set(self, request: dict) -> dict:
        try:
            waypoints = waypoints_of(request["waypoints"], self.map_frames)
        except RouteError as exc:
            return {"success": False, "message": str(exc)}
        if problem := self._misplaced(waypoints):
            return {"success": False, "message": problem}
        await self.patrol.halt("stopped: the route was replaced")
        self._replace(waypoints, "")
        await self.route.durable()
        return {"success": True, "message": f"{len(waypoints)} waypoints set"}

    async def _append(self, request: dict) -> dict:
        if len(self.route.waypoints) >= MAX_WAYPOINTS:
            return {"success": False, "waypoint_index": 0,
                    "message": f"a route has at most {MAX_WAYPOINTS} waypoints"}
        try:
            waypoint = waypoint_of(request["waypoint"], "waypoint", self.map_frames)
        except RouteError as exc:
            return {"success": False, "message": str(exc), "waypoint_index": 0}
        if problem := self._misplaced([waypoint], len(self.route.waypoints)):
            return {"success": False, "message": problem, "waypoint_index": 0}
        # a running patrol picks it up on its next leg
        self.route.set([*self.route.waypoints, waypoint], self.route.name)
        self._publish()
        await self.route.durable()
        index = len(self.route.waypoints) - 1
        return {"success": True, "message": f"waypoint {index} added", "waypoint_index": index}

    async def _clear(self, request: dict) -> dict:
        await self.patrol.halt("stopped: the route was cleared")
        self._replace([], "")
        await self.route.durable()
        return {"success": True, "message": "waypoints cleared"}

    async def _list(self, request: dict) -> dict:
        return list_reply(self.files.root, request["directory"], self.files.names)

    async def _save(self, request: dict) -> dict:
        name = request["name"]
        data = encode_route(self.route.waypoints)
        try:
            await asyncio.to_thread(self.files.write, name, data)
        except FileError as exc:
            return {"success": False, "message": str(exc)}
        self.route.set(self.route.waypoints, name)
        if await asyncio.to_thread(self.mapfiles.save_default, ROUTE_FILE, data):
            log.info("route %s is now the default route of map %s", name,
                     self.mapfiles.loaded.name)
        self._publish()
        await self.route.durable()
        return {"success": True, "message": f"Waypoints saved to: {name}"}

    async def _load(self, request: dict) -> dict:
        name = request["name"]
        try:
            if not self.files.exists(name):
                return {"success": False, "message": f"File not found: {name}"}
            data = await asyncio.to_thread(self.files.read, name)
            waypoints = decode_route(data, self.map_frames, f"route {name!r}")
        except (FileError, RouteError) as exc:
            return {"success": False, "message": str(exc)}
        await self.patrol.halt("stopped: another route was loaded")
        self._replace(waypoints, name)
        await self.route.durable()
        return {"success": True, "message": f"Waypoints loaded from: {name}"}

    def _apply_default(self, data: bytes) -> str:
        """The loaded map's ``route.yaml`` becomes the current route."""
        try:
            waypoints = decode_route(data, self.map_frames, ROUTE_FILE)
        except RouteError as exc:
            raise FileError(str(exc)) from None
        self.spawn(self.patrol.halt("stopped: a map was loaded"))
        self._replace(waypoints, ROUTE_FILE.removesuffix(".yaml"))
        return f"{len(waypoints)} waypoints loaded"

    # ------------------------------------------------------------------ patrol services
    async def _start(self, request: dict) -> dict:
        if not self.route.waypoints:
            return {"success": False, "message": "No waypoints loaded"}
        if problem := self._misplaced(self.route.waypoints):
            return {"success": False, "message": f"patrol refused: {problem}"}
        error = await self.patrol.begin(0)
        if error:
            return {"success": False, "message": error}
        return {"success": True, "message": "Patrol started from waypoint 0"}

    async def _resume(self, request: dict) -> dict:
        if not self.route.waypoints:
            return {"success": False, "message": "No waypoints loaded", "waypoint_index": 0}
        if problem := self._misplaced(self.route.waypoints):
            return {"success": False, "message": f"patrol refused: {problem}",
                    "waypoint_index": 0}
        try:
            pose = await self.localization.get_pose()
        except BackendError as exc:
            return {"success": False, "message": robot_error(exc, "robot pose unavailable"),
                    "waypoint_index": 0}
        index = nearest(self.route.waypoints, pose.x, pose.y)
        error = await self.patrol.begin(index)
        if error:
            return {"success": False, "message": error, "waypoint_index": index}
        return {"success": True, "message": f"Resuming from waypoint {index}",
                "waypoint_index": index}

    async def _stop(self, request: dict) -> dict:
        if not self.patrol.active:
            return {"success": True, "message": "no patrol is running"}
        await self.patrol.halt("stopped by request")
        return {"success": True, "message": "patrol stopped"}

"""What a server starts (:class:`StartPlan`, decided once from the settings), and the robots
it drives: one robot = its backend + its nodes, built by one function.

:func:`start_robot` is the one place a robot is made (persistence of per-robot state and
worker processes hook in here): its backend from its ``--robot`` entry, then its nodes, handed
its capabilities (:func:`~hitrobot_server.robot.factory.robot_of`: the motion gated) — on the
bus itself for the single unnamed robot (today's global names), on a :class:`NamespacedBus`
under ``/NAME/`` with TF frames ``NAME/…`` for a named one.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from .bus.core import Bus
from .bus.namespace import Namespace, NamespacedBus
from .config import Settings
from .nodes.assembly import (
    restored_summary,
    start_bridge_nodes,
    start_nodes,
    start_robot_nodes,
    start_sim_controls,
    stop_nodes,
)
from .nodes.base import Node
from .nodes.options import NodeOptions
from .robot.capabilities import Robot
from .robot.composed import ComposedBackend
from .robot.factory import build_backend, robot_of, shared_world, sim_identity
from .robot.locomotion import STAND_UP_SECONDS
from .robot.options import RobotEntry
from .robot.sim.backend import SimBackend
from .robot_state import RestStateBinder, open_state, report_restored
from .site import (
    SiteUnit,
    attach_site_map,
    move_in_bound,
    report_site,
    start_site,
    stop_site,
    stop_site_map,
)
from .state import StateBinding, StateStore

if TYPE_CHECKING:
    from .robot.sim.shared import SharedWorld

log = logging.getLogger(__name__)

ROBOT_ID_PARAM = "robot_id"


@dataclass(frozen=True)
class StartPlan:
    """Which parts one server process starts, decided once from its settings (by
    :func:`start_plan`); the server, :func:`start_planned` and the transports read it."""

    robots: tuple[RobotEntry, ...]  # each with its nodes; () = a bridge only (rosapi)
    fleet: bool  # named robots: the site part, one shared world, a namespace each
    site_map: str  # the robot whose map feeds the site's map manager ("": none does)
    demo: bool  # the tutorial servers (/add_two_ints, /fibonacci), beside a single robot
    record: Path | None  # record every bus message into this file from the start
    black_box: bool  # --black-box: the last seconds in memory, written on an incident
    zenoh: bool  # join other servers over the Zenoh link
    worker_id: int | None  # one of --workers: shared ports, parameters in worker 0
    tcp: bool  # the raw TCP port
    tls: bool  # wss:// and TLS on the TCP port
    warm_pool: bool = False  # a robot publishes a big map: the worker pool warmed at start

    @property
    def worker(self) -> bool:
        """One of ``--workers``: its ports are shared (SO_REUSEPORT) with the others."""
        return self.worker_id is not None

    @property
    def primary(self) -> bool:
        """Runs the robots and their nodes: a lone server, or worker 0 of ``--workers``."""
        return self.worker_id in (None, 0)


def start_plan(settings: Settings, *, robot: str | None = None) -> StartPlan:
    """What ``settings`` start; ``robot`` replaces the unnamed robot's spec (``replay``
    serves a recording in place of a robot: ``"none"``)."""
    entries = settings.robots or (RobotEntry("", robot or settings.robot.robot),)
    primary = settings.worker_id in (None, 0)  # a secondary worker: rosapi only
    fleet = primary and bool(settings.robots)
    mapped = next((e.name for e in settings.robots if e.spec != "none"), "")  # has a map
    return StartPlan(
        robots=entries if primary else (),
        fleet=fleet,
        site_map=(settings.nodes.site_map_robot or mapped) if fleet else "",
        demo=primary and not settings.robots and settings.nodes.demo_services,
        record=Path(settings.record.record) if settings.record.record else None,
        black_box=primary and settings.record.black_box > 0,  # where the robots are
        zenoh=settings.bus.zenoh,
        worker_id=settings.worker_id,
        tcp=bool(settings.transport.tcp_port),
        tls=settings.transport.ssl,
        # every worker of --workers too: each encodes the map for its own clients
        warm_pool=any(entry.spec != "none" for entry in entries),
    )


@dataclass
class RobotUnit:
    """One attached robot: ``name`` is ``""`` for the single unnamed robot."""

    name: str
    spec: str
    backend: ComposedBackend | None
    nodes: list[Node] = field(default_factory=list)
    robot: Robot | None = None  # what its nodes, tools and tests get: the gated capabilities
    bus: Bus | NamespacedBus | None = None  # what its nodes see
    state: StateBinding = field(default_factory=StateBinding)  # its state folder, once known
    binder: asyncio.Task | None = None  # a REST robot's: binds its folder when it answers

    @property
    def prefix(self) -> str:
        return f"/{self.name}" if self.name else ""


def robot_node_options(settings: Settings, entry: RobotEntry) -> NodeOptions:
    """One robot's node options; a named robot's TF frames are prefixed ``NAME/`` (the map
    frame stays the site's: one map shared by every robot)."""
    options = settings.node_options(entry.spec)
    if not entry.name:
        return options
    ns = Namespace(entry.name)
    s = options.slamware
    return dataclasses.replace(options, slamware=dataclasses.replace(
        s, robot_frame=ns.frame(s.robot_frame), laser_frame=ns.frame(s.laser_frame),
        odom_frame=ns.frame(s.odom_frame)))


async def start_robot(bus: Bus, settings: Settings, entry: RobotEntry, *,
                      world: SharedWorld | None = None, demo: bool = False,
                      on_bound: Callable[[StateStore], Awaitable[None]] | None = None
                      ) -> RobotUnit:
    """Build, start and wire one robot; on failure everything it started is stopped again.
    Its state folder (what an operator builds survives restarts) is opened first for a
    simulated robot, and bound once a REST robot says who it is (``on_bound`` is told)."""
    options = settings.robot_options(entry)
    unit = RobotUnit(entry.name, entry.spec, None)
    try:
        if options.robot == "sim":
            identity = sim_identity(options, entry.name)
            store = await open_state(settings.store.state_root, identity,
                                     settings.store.fresh)
            unit.state = StateBinding(store, identity)
        backend = unit.backend = build_backend(options, world, unit.state.store)
        if backend is not None:
            await backend.link.start()
        node_options = robot_node_options(settings, entry)
        robot: Robot | None = None  # what the nodes get: the motion behind the locomotion gate
        if backend is not None:
            robot = unit.robot = robot_of(backend, STAND_UP_SECONDS / node_options.time_scale)
        if not entry.name:
            unit.bus = bus
            unit.nodes = await start_nodes(bus, node_options, robot, unit.state, demo=demo)
        elif robot is not None:
            view = NamespacedBus(bus, Namespace(entry.name))
            view.params.set(ROBOT_ID_PARAM, entry.name)
            unit.bus = view
            unit.nodes = await start_robot_nodes(view, entry.name, node_options, robot,
                                                 unit.state)
        if isinstance(backend, SimBackend) and unit.bus is not None:
            unit.nodes.append(await start_sim_controls(unit.bus, backend.link, backend.controls))
        if unit.state.store is not None:
            # the simulator restores itself from the store (a REST robot keeps its own state)
            own = backend.restored if backend is not None else []
            report_restored(unit.state.store, [*own, *restored_summary(unit.nodes)])
        elif backend is not None:  # a REST robot: its state folder once it says who it is
            binder = RestStateBinder(backend, unit.state, options.robot,
                                     settings.store.state_root, settings.store.fresh,
                                     lambda: unit.nodes, on_bound)
            unit.binder = asyncio.ensure_future(binder.run())
    except BaseException:
        await stop_robot(unit)
        raise
    return unit


async def stop_robot(unit: RobotUnit) -> None:
    if unit.binder is not None:
        unit.binder.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await unit.binder
        unit.binder = None
    await stop_nodes(unit.nodes)
    unit.nodes.clear()
    if unit.backend is not None:
        with contextlib.suppress(Exception):
            await unit.backend.link.stop()
        unit.backend = unit.robot = None
    if unit.state.store is not None:
        await unit.state.store.close()
        unit.state = StateBinding()


async def start_planned(bus: Bus, settings: Settings,
                        plan: StartPlan) -> tuple[SiteUnit, list[RobotUnit]]:
    """The site and every robot of the plan. The single unnamed robot brings its own nodes
    (today's layout; the site is empty); named robots share the site (its folder, nodes and map
    manager, started with the robot that feeds it) and one simulated world; no robot: the
    bridge's rosapi. All or nothing: a robot that fails to start stops everything started
    before it."""
    if not plan.robots:
        return SiteUnit(nodes=await start_bridge_nodes(bus, settings.node_options())), []
    if not plan.fleet:
        return SiteUnit(), [await start_robot(bus, settings, plan.robots[0], demo=plan.demo)]
    site = SiteUnit()
    units: list[RobotUnit] = []
    sims = any(e.spec == "sim" for e in plan.robots)
    world = shared_world(settings.robot_options()) if sims else None
    first = next((e for e in plan.robots if e.spec != "none"), None)  # held the site's map
    later = first is not None and first.spec != "sim"  # a REST robot: its folder once bound
    try:
        site = await start_site(bus, settings, first_robot_folder(settings, first), later=later)
        for entry in plan.robots:
            bound = (lambda store: move_in_bound(site, store)) if later and entry is first \
                else None
            unit = await start_robot(bus, settings, entry, world=world, on_bound=bound)
            units.append(unit)
            if entry.name == plan.site_map and unit.robot is not None and unit.bus is not None:
                await attach_site_map(site, unit.bus, robot_node_options(settings, entry),
                                      unit.robot)
        report_site(site)
    except BaseException:
        await stop_robots(site, units)
        raise
    return site, units


def first_robot_folder(settings: Settings, first: RobotEntry | None) -> str | None:
    """Where a server kept the site's map-manager sections before the site had a part of its
    own: its first robot with a map's (``first``) folder. A simulated robot's is known now; a
    REST robot's only once it answers (``None``)."""
    if first is None or first.spec != "sim":
        return None
    return sim_identity(settings.robot_options(first), first.name)


async def stop_robots(site: SiteUnit, units: list[RobotUnit]) -> None:
    """The site's map manager (it drives its robot), the robots in reverse start order, then
    the site's nodes and folder."""
    await stop_site_map(site)
    for unit in reversed(units):
        await stop_robot(unit)
    await stop_site(site)

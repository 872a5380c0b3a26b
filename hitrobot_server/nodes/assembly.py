"""The in-process nodes a server runs, in start order."""

from __future__ import annotations

from zoneinfo import ZoneInfo

from ..bus.core import Bus
from ..bus.namespace import SITE_WIDE, SITE_WIDE_TOPICS
from ..bus.rosout import SERVER_NODE
from ..protocol.access import WHOAMI, WHOAMI_NODE
from ..robot.backend import Link
from ..robot.capabilities import Robot
from ..robot.sim.backend.controls import SimControls
from ..state import StateBinding
from .base import Node
from .conventional import ConventionalNode
from .demo import DemoServices
from .diagnostics import DiagnosticsNode
from .fleet import ChargePolicy, FleetMemberNode, FleetNode
from .graph import GraphNodeService
from .ground.claims import MotionClaims
from .ground.messages import slamware_topic
from .ground.parameters import serve_parameters
from .intelligent_navigation import IntelligentNavigationNode
from .locomotion import LocomotionNode
from .map_manager import MapManager
from .mapfiles import MapFilesNode
from .move_base import MoveBaseNode
from .nav2_actions import Nav2ActionsNode
from .navigation import NavigationNode
from .options import NodeOptions
from .patrol import PatrolNode
from .pointclouds import PointCloudNode
from .rosapi import ROS_PARAMS, Rosapi
from .shell import ShellNode
from .sim_controls import SimControlsNode
from .slamware import SlamwareNode
from .tf_republisher import TFRepublisherNode


async def start_nodes(bus: Bus, settings: NodeOptions, robot: Robot | None,
                      state: StateBinding | None = None, *, demo: bool = False) -> list[Node]:
    """Create and start every node; robot-facing nodes only when a robot is attached, the
    tutorial servers when the start plan says ``demo``. ``state``: that robot's state folder
    (what the operator builds survives restarts)."""
    nodes: list[Node] = [Rosapi(bus, settings), TFRepublisherNode(bus)]
    if demo:
        nodes.append(DemoServices(bus))
    if robot is not None:
        nodes += robot_nodes(bus, settings, robot, state=state)
    # runs without a robot too (the bridge part)
    nodes.append(DiagnosticsNode(bus, robot, state))
    await _start(nodes)
    return nodes


async def start_bridge_nodes(bus: Bus, settings: NodeOptions) -> list[Node]:
    """A secondary worker of ``--workers``: its own rosapi only (lists, types, time); the
    parameters, the robot and every other node live in worker 0, reached over the link."""
    return [Rosapi(bus, settings, params=False)]


def robot_nodes(bus: Bus, settings: NodeOptions, robot: Robot,
                state: StateBinding | None = None, *, map_manager: bool = True) -> list[Node]:
    """The robot-facing nodes, in start order, each handed the capabilities it uses. They all
    drive the robot through the locomotion gate (``robot.motion``), so a sitting robot refuses
    motion whichever interface asks. ``map_manager``: the single robot's own (its POIs in its
    state folder); a robot of a fleet has none: the site's (:func:`site_map`) serves
    every robot, fed by one robot's map."""
    link, motion, localization = robot.link, robot.motion, robot.localization
    frame = settings.slamware.map_frame
    # Nodes handed to other nodes (no node imports another; they meet here or on the bus):
    # the shell cancels move_base's goals, the route and graph nodes keep their default files
    # beside the loaded map (mapfiles as MapDefaults) and locomotion names its map-frame
    # odometry after the loaded map. Navigation reads the POIs over the bus, as the fleet does.
    # move_base is handed the Slamware node's goal topic (/move_base_simple/goal) and runs its
    # simple goals as action goals, as ROS's move_base does; the Slamware node, always beside
    # it here, is told to leave them alone (simple_goals=False).
    # They share who took the robot over with a /cmd_vel (claims): a goal, a navigation or a
    # patrol it ended names them.
    goal_topic = settings.slamware.goal_topic
    claims = MotionClaims()
    move_base = MoveBaseNode(bus, link, motion, localization, frame,
                             simple_goal=slamware_topic(goal_topic) if goal_topic else None,
                             claims=claims)
    mapfiles = MapFilesNode(bus, link, localization, settings)
    nodes = [
        SlamwareNode(bus, robot, settings.slamware, simple_goals=False, state=state,
                     claims=claims, authenticate=settings.authenticate),
        ConventionalNode(bus, link, localization, frame),
        move_base,
        ShellNode(bus, robot, settings.authenticate, move_base.cancel_all),
        *([map_manager_of(bus, settings, robot, state)] if map_manager else []),
        NavigationNode(bus, link, motion, localization, claims),
        PointCloudNode(bus, link, robot.sensors, frame),
        Nav2ActionsNode(bus, link, motion, localization, robot.sensors, frame, claims),
        IntelligentNavigationNode(bus, robot, frame),
        mapfiles,
        PatrolNode(bus, link, motion, localization, settings, mapfiles, state, claims),
        GraphNodeService(bus, link, motion, localization, settings, mapfiles, state),
        LocomotionNode(bus, link, robot.locomotion, robot.sensors, robot.power, settings,
                       mapfiles.loaded),
    ]
    serve_parameters(nodes, settings.params_filter.allows)  # ROS 2's view of their params
    return nodes


def map_manager_of(bus: Bus, settings: NodeOptions, robot: Robot,
                   state: StateBinding | None) -> MapManager:
    """A map manager fed by ``robot``'s map (its SLAM layer; the masks become that robot's
    blocked areas), its sections in ``state``."""
    return MapManager(bus, robot.link, robot.maps, robot.localization, settings, state)


async def start_site_nodes(bus: Bus, settings: NodeOptions,
                           state: StateBinding | None = None) -> list[Node]:
    """The site-wide nodes of a server with named robots: rosapi, TF, the bridge's
    diagnostics and the fleet (the site's map manager starts with the robot that feeds it,
    :func:`site_map`). ``state``: the site's state folder (the fleet's tasks, history,
    schedules and zones)."""
    policy = ChargePolicy(charge_below=settings.charge_below, charge_until=settings.charge_until)
    zone = ZoneInfo(settings.site_timezone) if settings.site_timezone else None
    fleet = FleetNode(bus, settings.slamware.map_frame, state, policy, zone,
                      settings.fleet_clock)
    nodes: list[Node] = [Rosapi(bus, settings), TFRepublisherNode(bus), DiagnosticsNode(bus),
                         fleet]
    await _start(nodes)
    return nodes


def site_map(bus: Bus, settings: NodeOptions, robot: Robot, state: StateBinding) -> Node:
    """The site's map manager (POIs, masks, the composed ``/map``, saved maps), on the view
    ``bus`` of the robot whose map feeds it, its sections in the site's folder ``state``
    (``/map_manager`` and ``/map`` are site-wide names: every robot's view reaches them); the
    site starts it."""
    return map_manager_of(bus, settings, robot, state)


async def start_robot_nodes(bus: Bus, name: str, settings: NodeOptions, robot: Robot,
                            state: StateBinding | None = None) -> list[Node]:
    """Robot ``name``'s nodes on its namespaced view ``bus``, with its own diagnostics and its
    state for the fleet (the site's map manager is not theirs)."""
    nodes = robot_nodes(bus, settings, robot, state, map_manager=False)
    nodes += [DiagnosticsNode(bus, robot, state, bridge=False),
              FleetMemberNode(bus, robot, name)]
    await _start(nodes)
    return nodes


async def start_sim_controls(bus: Bus, link: Link, controls: SimControls) -> Node:
    """A simulated robot's controls (``/sim/…``, ``/NAME/sim/…`` on a robot's view)."""
    node = SimControlsNode(bus, link, controls)
    await node.start()
    return node


async def _start(nodes: list[Node]) -> None:
    for node in nodes:
        await node.start()


def restored_summary(nodes: list[Node]) -> list[str]:
    """What the nodes took back from the state folder, as phrases for the start-up log."""
    return [phrase for node in nodes for phrase in node.restored()]


NODE_CLASSES: tuple[type[Node], ...] = (
    TFRepublisherNode, DemoServices, DiagnosticsNode, FleetNode, FleetMemberNode, SlamwareNode,
    ConventionalNode, MoveBaseNode, ShellNode, MapManager, NavigationNode, PointCloudNode,
    Nav2ActionsNode, IntelligentNavigationNode, MapFilesNode, PatrolNode, GraphNodeService,
    LocomotionNode, SimControlsNode,
)
"""Every node class the assembly makes (rosapi's names are the bus's site-wide ones, and
roscore's parameters it sets, ``ROS_PARAMS``)."""
BESIDE_THE_NODES = ("/record", "/recorder", "/replay", "/replay_launcher", "/black_box")
"""Global names served beside the nodes, by the recorder and the player (``record/``, which
the nodes may not import; a test checks these are still theirs)."""


def reserved_names() -> frozenset[str]:
    """First name segments a robot may not be named, collected from what serves them: the
    bus's site-wide names and its own node, the recorder's and the player's, and the global
    names every node class declares (``Node.GLOBAL_NAMES``). The robot-name check of the
    configuration is handed this set."""
    names = [*SITE_WIDE, *SITE_WIDE_TOPICS, SERVER_NODE, *BESIDE_THE_NODES, *ROS_PARAMS,
             WHOAMI, WHOAMI_NODE,
             *(name for cls in NODE_CLASSES for name in cls.GLOBAL_NAMES)]
    return frozenset(name.strip("/").split("/")[0] for name in names)


async def stop_nodes(nodes: list[Node]) -> None:
    """Stop in reverse start order, so nodes built on others go first."""
    for node in reversed(nodes):
        await node.stop()

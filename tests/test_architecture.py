"""The floors of ARCHITECTURE.md, checked: no package of hitrobot_server imports a floor above
its own. Imports are read with ``ast`` (every import, also those inside functions), so the rule
holds however modules move within a package."""

from __future__ import annotations

import ast
from pathlib import Path

import hitrobot_server

PACKAGE = Path(hitrobot_server.__file__).parent

# What each floor (hitrobot_server.<name>) may import from the project, besides itself and the
# root package's __init__ (the version). Bottom first.
BASE = {"types", "tf_buffer", "signals", "procmem"}  # pure helpers, no project imports
ALLOWED: dict[str, set[str]] = {
    "types": set(),
    "tf_buffer": set(),
    "signals": set(),
    "procmem": set(),
    "state": set(),  # the robot's state folder: below the robot and the nodes that write it
    "protocol": {"types"},
    "bus": {"types"},  # the bus knows no wire format (wire/ and protocol/ sit above it)
    "wire": {"bus"},  # a message's memo of encodings by typed key, frames: no protocol
    "robot": {"types", "tf_buffer", "state"},
    "session": {"wire", "bus", "protocol", "types"},
    "transport": {"session", "protocol", "types"},
    "nodes": {"bus", "robot", "protocol", "types", "tf_buffer", "procmem", "state"},
    # a bus tap and a player, like a node without robot
    "record": {"wire", "bus", "protocol", "types", "signals"},
    "conformance": {"protocol", "types"},  # a client tool: it talks to servers over sockets
    # VDA 5050 vehicles: drive the robots over the bus, read them as a node does, MQTT out
    "vda5050": {"bus", "nodes", "robot", "types"},
    # the top: assembles the floors, so it may import any of them
    "config": {"session", "transport", "bus", "nodes", "robot", "record", "protocol", "types",
               "state", "vda5050"},
    "server": {"config", "robots", "site", "transport", "session", "bus", "nodes", "robot",
               "record", "protocol", "types", "state", "metrics", "vda5050"},
    # /metrics and /healthz: read the server's parts when scraped (beside server, below it)
    "metrics": {"robots", "site", "state", "session", "bus", "record", "wire", "procmem"},
    # one robot = backend + nodes (+ its state folder, robot_state)
    "robots": {"config", "bus", "nodes", "robot", "types", "state", "robot_state", "site"},
    "robot_state": {"nodes", "robot", "state"},
    # the site of a fleet: its folder (moved into once), its nodes, its map manager
    "site": {"config", "bus", "nodes", "robot", "state", "robot_state"},
    "commands": {"robot", "signals", "config", "types", "server", "robots", "record", "state",
                 "protocol"},
    "workers": {"config", "signals", "bus"},  # the --workers parent (bus: endpoint parsing)
    "cli": {"config", "server", "signals", "conformance", "commands", "workers"},
    # the manual's flags page, written from the parsers of the command line and its tools
    "docs_flags": {"cli", "config", "commands", "conformance"},
    "__main__": {"cli"},
}

# Known upward imports, each with its reason. Empty: keep it so.
EXCEPTIONS: dict[tuple[str, str], str] = {}

# Inside nodes/ (ARCHITECTURE.md, "Inside nodes/"): each module or package of nodes/ is one
# node, except the ground floor below them all and the assembly above them all. A node imports
# the ground and itself, never another node; the ground imports no node; only the assembly
# imports nodes. base.py (Node, RobotNode) and options.py (NodeOptions) belong to the ground but
# stay at nodes/ top: the floors above name them (server, robots, config).
NODES_GROUND = {"ground", "base", "options"}
NODES_ASSEMBLY = "assembly"
# Known node → node imports, each with its reason. Empty: keep it so.
NODE_EXCEPTIONS: dict[tuple[str, str], str] = {}

# Inside robot/ (ARCHITECTURE.md, "Inside robot/"): planning/ (grid, costmap, planner, path
# search, scan matching) sits below both backends; the simulator and the REST client never
# import each other; the sim-device (the simulator served over the REST API) sits above both.
# The modules at robot/'s top ("top": the capability protocols, the model, the locomotion gate,
# relocalization) use planning/ but no backend; only the factory, which builds them, does.
ROBOT_PARTS: dict[str, set[str]] = {
    "planning": set(),
    "sim": {"planning"},
    "rest": {"planning"},
    "device": {"planning", "sim", "rest"},
    "top": {"planning"},
    "factory": {"planning", "sim", "rest"},
}


def floor_of(module: list[str]) -> str:
    """``['hitrobot_server', 'nodes', 'slamware', 'node']`` → ``'nodes'``."""
    return module[1] if len(module) > 1 else ""


def imported_modules(source: str, module: list[str], is_package: bool) -> list[list[str]]:
    """The project modules one file imports, as dotted parts, relative imports resolved."""
    here = module if is_package else module[:-1]
    found: list[list[str]] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [a.name.split(".") for a in node.names if a.name.split(".")[0] == PACKAGE.name]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - (node.level - 1)]
                if node.module:
                    found.append(base + node.module.split("."))
                else:
                    found += [base + [a.name] for a in node.names]
            elif node.module and node.module.split(".")[0] == PACKAGE.name:
                found.append(node.module.split("."))
    return found


def violations(source: str, module: list[str], is_package: bool) -> list[str]:
    floor = floor_of(module)
    bad = []
    for target in imported_modules(source, module, is_package):
        dest = floor_of(target)
        if dest in ("", floor, "__version__"):
            continue
        if dest not in ALLOWED.get(floor, set()) and (floor, dest) not in EXCEPTIONS:
            bad.append(f"{'.'.join(module)} imports {'.'.join(target)} ({floor} → {dest})")
    return bad


def node_of(module: list[str]) -> str | None:
    """``['hitrobot_server', 'nodes', 'map_manager', 'node']`` → ``'map_manager'``; None
    outside nodes/ (and for the nodes package itself)."""
    return module[2] if len(module) > 2 and module[1] == "nodes" else None


def node_violations(source: str, module: list[str], is_package: bool) -> list[str]:
    """A node importing another node, or the ground importing a node (the assembly may)."""
    here = node_of(module)
    if here is None or here == NODES_ASSEMBLY:
        return []
    bad = []
    for target in imported_modules(source, module, is_package):
        dest = node_of(target)
        if dest is None or dest == here or dest in NODES_GROUND:
            continue
        if (here, dest) not in NODE_EXCEPTIONS:
            kind = "the ground" if here in NODES_GROUND else "a node"
            bad.append(f"{'.'.join(module)} imports {'.'.join(target)} ({kind} imports node "
                       f"{dest})")
    return bad


def robot_part_of(module: list[str]) -> str | None:
    """``['hitrobot_server', 'robot', 'sim', 'runner']`` → ``'sim'``, a module at robot/'s top
    → ``'top'`` (the factory its own); None outside robot/ and for robot/ itself."""
    if len(module) < 3 or module[1] != "robot":
        return None
    if module[2] in ROBOT_PARTS:
        return module[2]
    return "top" if len(module) == 3 else None


def robot_violations(source: str, module: list[str], is_package: bool) -> list[str]:
    """A part of robot/ importing a part it may not (planning or a top module importing a
    backend, one backend importing the other); every part may import the top modules."""
    here = robot_part_of(module)
    if here is None:
        return []
    bad = []
    for target in imported_modules(source, module, is_package):
        dest = robot_part_of(target)
        if dest not in (None, here, "top") and dest not in ROBOT_PARTS[here]:
            bad.append(f"{'.'.join(module)} imports {'.'.join(target)} (robot/{here} → "
                       f"robot/{dest})")
    return bad


def project_modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = [PACKAGE.name, *path.relative_to(PACKAGE).with_suffix("").parts]
        is_package = parts[-1] == "__init__"
        if is_package:
            parts = parts[:-1]
        yield path, parts, is_package


def tree_violations(check) -> list[str]:
    """``check`` (:func:`violations` or :func:`node_violations`) run on every project module."""
    bad = []
    for path, parts, is_package in project_modules():
        bad += check(path.read_text(encoding="utf-8"), parts, is_package)
    return bad


def every_import():
    """(importing module, imported module) for every import in the project, as dotted parts."""
    for path, parts, is_package in project_modules():
        for target in imported_modules(path.read_text(encoding="utf-8"), parts, is_package):
            yield parts, target


def test_every_floor_is_placed():
    """A new subpackage or top-level module gets a place in ALLOWED (and ARCHITECTURE.md)."""
    floors = {floor_of(parts) for _, parts, _ in project_modules()} - {""}
    assert floors <= set(ALLOWED), f"not placed on a floor: {sorted(floors - set(ALLOWED))}"


def test_no_layer_imports_upward():
    bad = tree_violations(violations)
    assert not bad, "upward imports:\n" + "\n".join(bad)


def test_base_floors_import_nothing_of_ours():
    assert all(not ALLOWED[name] for name in BASE)


def test_exceptions_are_still_needed():
    """An exception that no module uses any more is removed, not kept as a hole."""
    used = {(floor_of(module), floor_of(target)) for module, target in every_import()}
    assert set(EXCEPTIONS) <= used


def test_the_rule_catches_an_upward_import():
    """The checker itself: a node importing the session, relative or absolute, or the bus
    importing a node, is reported; a node importing the bus is not."""
    node = ["hitrobot_server", "nodes", "slamware", "node"]
    assert violations("from ...session.session import Session\n", node, False)
    assert violations("import hitrobot_server.transport.tcp\n", node, False)
    assert violations("def f():\n    from ...transport import tcp\n", node, False)
    assert violations("from ..nodes import base\n", ["hitrobot_server", "bus", "core"], False)
    assert violations("from .. import nodes\n", ["hitrobot_server", "bus"], True)
    assert not violations("from ...bus.core import Bus\n", node, False)
    assert not violations("from . import params\n", node, False)


def test_no_node_imports_another_node():
    bad = tree_violations(node_violations)
    assert not bad, "node → node imports (share it in nodes/ground, or wire it in assembly):\n" \
        + "\n".join(bad)


def test_node_exceptions_are_still_needed():
    """A node → node exception no module uses any more is removed, not kept as a hole."""
    used = {(node_of(module), node_of(target)) for module, target in every_import()}
    assert set(NODE_EXCEPTIONS) <= used


def test_the_nodes_rule_catches_a_node_importing_another():
    """The checker itself: a node importing another node (relative, absolute, inside a
    function) or the ground importing a node is reported; a node importing the ground or its
    own package, and the assembly importing any node, are not."""
    patrol = ["hitrobot_server", "nodes", "patrol"]
    manager = ["hitrobot_server", "nodes", "map_manager", "node"]
    ground = ["hitrobot_server", "nodes", "ground", "messages"]
    assert node_violations("from .mapfiles import MapFilesNode\n", patrol, False)
    assert node_violations("import hitrobot_server.nodes.graph\n", patrol, False)
    assert node_violations("def f():\n    from ..patrol import PatrolNode\n", manager, False)
    assert node_violations("from .. import shell\n", ground, False)
    assert node_violations("from ..assembly import robot_nodes\n", ground, False)
    assert node_violations("from .assembly import robot_nodes\n", patrol, False)
    assert not node_violations("from .ground.namedfiles import NamedFiles\n", patrol, False)
    assert not node_violations("from .base import RobotNode\n", patrol, False)
    assert not node_violations("from .layers import Grid\n", manager, False)
    assert not node_violations("from . import mapstore\n", ground, False)
    assert not node_violations("from ..base import require_finite\n", ground, False)
    assert not node_violations("from .patrol import PatrolNode\n",
                               ["hitrobot_server", "nodes", "assembly"], False)


def test_the_robot_parts_keep_their_floors():
    bad = tree_violations(robot_violations)
    assert not bad, "robot/ part imports (planning below sim and rest, which never meet):\n" \
        + "\n".join(bad)


def test_the_robot_rule_catches_a_backend_importing_the_other():
    """The checker itself: rest importing sim, sim importing rest, planning importing either
    are reported; both backends importing planning, and the device importing both, are not."""
    rest = ["hitrobot_server", "robot", "rest", "maps"]
    sim = ["hitrobot_server", "robot", "sim", "simulator"]
    planning = ["hitrobot_server", "robot", "planning", "search"]
    device = ["hitrobot_server", "robot", "device", "server"]
    assert robot_violations("from ..sim.costmap import Costmap\n", rest, False)
    assert robot_violations("import hitrobot_server.robot.rest.shapes\n", sim, False)
    assert robot_violations("from ..sim.navigation import Navigator\n", planning, False)
    assert robot_violations("def f():\n    from ..rest import paths\n", planning, False)
    top = ["hitrobot_server", "robot", "relocalization"]
    assert robot_violations("from .sim.localization import Localizer\n", top, False)
    assert not robot_violations("from .planning.matching import scan_points\n", top, False)
    assert not robot_violations("from .sim.backend import SimBackend\n",
                                ["hitrobot_server", "robot", "factory"], False)
    assert not robot_violations("from ..planning.costmap import Costmap\n", rest, False)
    assert not robot_violations("from ..planning.grid import GridSpec\n", sim, False)
    assert not robot_violations("from ..sim.backend import SimBackend\n", device, False)
    assert not robot_violations("from ..model import Pose2D\n", planning, False)

"""The in-process nodes a server runs, in start order."""

from __future__ import annotations

from ..bus.core import Bus
from ..config import Settings
from ..robot.backend import RobotBackend
from .base import Node
from .rosapi import Rosapi


async def start_nodes(bus: Bus, settings: Settings, backend: RobotBackend | None) -> list[Node]:
    """Create and start every node; robot-facing nodes only when a robot is attached."""
    nodes: list[Node] = [Rosapi(bus, settings)]
    if backend is not None:
        from .slamware import SlamwareNode

        slamware = SlamwareNode(bus, backend, settings.slamware)
        nodes.append(slamware)
        await slamware.start()
        from .conventional import ConventionalNode
        from .move_base import MoveBaseNode
        from .shell import ShellNode

        conventional = ConventionalNode(bus, backend, settings.slamware.map_frame)
        move_base = MoveBaseNode(bus, backend, settings.slamware.map_frame)
        shell = ShellNode(bus, backend, settings.authenticate, move_base)
        for node in (conventional, move_base, shell):
            nodes.append(node)
            await node.start()
        from .map_manager import MapManager
        from .navigation import NavigationNode

        map_manager = MapManager(bus, backend, settings)
        navigation = NavigationNode(bus, backend, map_manager.pois.get)
        for node in (map_manager, navigation):
            nodes.append(node)
            await node.start()
    from .diagnostics import DiagnosticsNode

    diagnostics = DiagnosticsNode(bus, backend)  # runs without a robot too (bridge part)
    nodes.append(diagnostics)
    await diagnostics.start()
    return nodes


async def stop_nodes(nodes: list[Node]) -> None:
    """Stop in reverse start order, so nodes built on others go first."""
    for node in reversed(nodes):
        stop = getattr(node, "stop", None)
        if stop is not None:
            await stop()
        else:
            node.close()

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
    return nodes


async def stop_nodes(nodes: list[Node]) -> None:
    """Stop in reverse start order, so nodes built on others go first."""
    for node in reversed(nodes):
        stop = getattr(node, "stop", None)
        if stop is not None:
            await stop()
        else:
            node.close()

"""How the map manager's parts carry a request out: in the background, its failure (or
success text) going to the publisher as a status."""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from ...bus.topics import Message
from ..base import RobotNode
from ..ground.mapstore import StoreError
from ..ground.memory import NotSaved
from ..ground.requests import answer, require_robot
from .layers import LayerError
from .mapio import MapFileError
from .pois import PoiError

REQUEST_ERRORS = (StoreError, MapFileError, PoiError, LayerError, NotSaved)
"""A request's own errors: the publisher hears their text, as it does a robot error's."""


def job(node: RobotNode, message: Message, what: str,
        work: Callable[[], Awaitable[str | None]], needs_robot: bool = True) -> None:
    """Run ``work`` in the background (refused at once when it needs the robot and the robot
    is away); its failure (or success text) goes to the publisher as a status."""
    if needs_robot:
        require_robot(node.link, what)
    node.spawn(answer(message.reply, what, work(), known=REQUEST_ERRORS))

"""What a Foxglove op group (channels, subscribe, publish, services, parameters, graph) uses
of its client's session: written down in one place, like the rosbridge ``OpContext``."""

from __future__ import annotations

import asyncio
from collections.abc import Coroutine
from typing import Any, Protocol

from ...bus.cdr import Ros2Codec
from ...bus.core import Bus
from ...bus.topics import Origin
from ..offload import WorkerPool
from ..options import SessionOptions
from .frames import FoxgloveOutput
from .shared import FoxgloveShared


class FoxgloveContext(Protocol):
    """One Foxglove client as its op groups see it (also the owner of what it holds on the
    bus)."""

    bus: Bus
    settings: SessionOptions
    shared: FoxgloveShared
    codec: Ros2Codec
    node: str  # the client's node name on the bus
    origin: Origin
    subprotocol: str  # the protocol version it asked for (v1 or the SDK's)
    out: FoxgloveOutput
    pool: WorkerPool  # the server's worker processes: big decodes off the event loop

    def spawn(self, coro: Coroutine[Any, Any, Any]) -> asyncio.Task:
        """Run a coroutine that is cancelled when the client goes."""
        ...

"""What an op group (publish, subscribe, services, actions) uses of its client's session.

The op groups get this narrow view instead of the whole :class:`~.session.Session`, so what
they can reach is written down in one place. The session itself is the context (it is also
the owner the bus files their publishers, subscribers and providers under).
"""

from __future__ import annotations

import asyncio
from collections.abc import Coroutine
from typing import Any, Protocol

from ...bus.core import Bus
from ...bus.topics import Origin
from ...protocol.ops import CallService, SendActionGoal, Subscribe
from ..offload import WorkerPool
from ..options import SessionOptions
from ..outbox import Outbox
from .frames import FrameBuilder


class OpContext(Protocol):
    """One client as its op groups see it: its bus, settings, identity and replies."""

    bus: Bus
    settings: SessionOptions
    node: str  # the client's node name on the bus
    transport: str  # "ws" or "tcp": binary compressions need WebSocket frames
    outbox: Outbox  # where its subscriptions queue topic data (per-topic streams, drops)
    pool: WorkerPool  # the server's worker processes: big encodings off the event loop
    frames: FrameBuilder  # builds its frames (the server's: fragment ids never repeat)

    @property
    def origin(self) -> Origin:
        """Who sent the op (changes when the client authenticates)."""
        ...

    def status(self, level: str, msg: str, op_id: Any = None) -> None:
        """Queue a ``status`` reply (filtered by the client's status level)."""
        ...

    def send(
        self, obj: dict, *, fragment_size: int | None = None, compression: str = "none"
    ) -> None:
        """Queue a reply op."""
        ...

    def spawn(self, coro: Coroutine[Any, Any, Any]) -> asyncio.Task:
        """Run a coroutine that is cancelled when the client goes."""
        ...

    def fragment_size(self, op: Subscribe | CallService | SendActionGoal) -> int | None:
        """The op's ``fragment_size``, raised to the floor (with a warning) when below it."""
        ...

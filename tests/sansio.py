"""Sessions without sockets, the way the ``websockets`` library tests its protocol objects:
frames go into ``Session.receive`` and the test drains ``Session.outbox`` itself.

The bus, its bridge nodes (rosapi, tf, diagnostics) and the sessions are the real ones; only
the transport is left out, so a test of an op is deterministic: an op is handled by the time
``send`` returns, and nothing needs a sleep to "let the server catch up".
"""

from __future__ import annotations

import asyncio
import json
from collections import deque
from pathlib import Path

from hitrobot_server.bus.core import Bus
from hitrobot_server.nodes.assembly import start_nodes, stop_nodes
from hitrobot_server.nodes.base import Node
from hitrobot_server.nodes.options import NodeOptions
from hitrobot_server.session.options import SessionOptions
from hitrobot_server.session.rosbridge.session import Session, Shared
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import ProtocolClient, decode_frame


class SessionClient(ProtocolClient):
    """One client: text frames in (as a WebSocket transport passes them), frames out of the
    session's outbox, decoded."""

    def __init__(self, session: Session):
        super().__init__()
        self.session = session
        self._pending: deque[dict] = deque()

    async def send(self, obj: dict | str) -> None:
        self.session.receive(obj if isinstance(obj, str) else json.dumps(obj))

    async def recv(self, timeout: float = 5.0) -> dict:
        while not self._pending:
            frames = await asyncio.wait_for(self.session.outbox.get(), timeout)
            if frames is None:
                raise ConnectionError("the session closed its outbox")
            self.session.outbox.sent()
            self._pending.extend(decode_frame(data, binary) for data, binary in frames)
        msg = self._pending.popleft()
        self.seen.append(msg)
        return msg

    async def close(self) -> None:
        """The connection is gone (what a transport reports when its socket closes)."""
        self.session.close()


class Hub:
    """A bus with the bridge nodes a robot-less server runs, and sessions on it."""

    def __init__(self, map_store: Path, **options):
        self.bus = Bus(TypeRegistry.default(), unregister_timeout=0.2)
        self.options = SessionOptions(**options)
        self.shared = Shared.for_options(self.options)
        self.node_options = NodeOptions(  # rosapi lists what the session's globs allow
            map_store=map_store, authenticate=self.options.authenticate,
            topics_glob=self.options.topics_glob, services_glob=self.options.services_glob,
            params_glob=None,
        )
        self.nodes: list[Node] = []
        self.clients: list[SessionClient] = []

    async def start(self) -> Hub:
        self.nodes = await start_nodes(self.bus, self.node_options, None)
        return self

    def open(self, transport: str = "ws") -> SessionClient:
        """A session as the given transport makes it ("ws": binary frames allowed)."""
        session = Session(self.bus, self.options, peer="sans-io", transport=transport,
                          shared=self.shared)
        client = SessionClient(session)
        self.clients.append(client)
        return client

    async def stop(self) -> None:
        for client in self.clients:
            await client.close()
        await stop_nodes(self.nodes)
        self.shared.pool.shutdown()  # the worker processes, as the server's stop does

"""WebSocket transport: frames in → Session.receive; Session.outbox → frames out.

The subprotocol a client asks for picks its session: ``foxglove.websocket.v1`` or
``foxglove.sdk.v1`` a :class:`FoxgloveSession`, anything else (or nothing) the rosbridge
:class:`Session`, as before. Both have the same ``receive``/``outbox``/``close``.

Plain HTTP GETs on the same port are answered by ``http_handler`` (the web UI), as
decisions.md asks: one port for the page and the bridge.
"""

from __future__ import annotations

import asyncio
import inspect
import logging
from collections.abc import Awaitable, Callable, Sequence

from websockets.asyncio.server import Server, ServerConnection, broadcast, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response
from websockets.protocol import State
from websockets.typing import Subprotocol

from ..protocol.foxglove import SUBPROTOCOLS
from ..session.foxglove import FoxgloveSession
from .connection import (
    DIRECT_WRITE_LIMIT,
    ClientSession,
    SessionFactory,
    keep_reading,
    run_session,
)
from .http import QuietHttpLog
from .tls import HandshakeGate, peer_address

log = logging.getLogger(__name__)

FoxgloveFactory = Callable[[str, str], FoxgloveSession]  # (peer, subprotocol)
HttpHandler = Callable[[ServerConnection, Request], Response | Awaitable[Response] | None]

# A message bigger than this goes out as WebSocket continuation frames of this size, so that
# writing a 40 MB map is many short steps of the event loop instead of one of 100+ ms. Clients
# see one message (RFC 6455 fragmentation, reassembled by every WebSocket implementation).
CHUNK_BYTES = 1024 * 1024


def choose_subprotocol(offered: Sequence[str], foxglove: bool) -> str | None:
    """The first Foxglove subprotocol the client offers (when Foxglove is served), else none:
    the rosbridge protocol, exactly as for a client that offers nothing."""
    if foxglove:
        for name in offered:
            if name in SUBPROTOCOLS:
                return name
    return None


def direct_writer(ws: ServerConnection):
    """Synchronous write while the socket keeps up (``broadcast`` to one connection)."""

    def write(frames: list) -> bool:
        transport = ws.transport
        if (
            ws.protocol.state is not State.OPEN
            or transport is None
            or transport.get_write_buffer_size() > DIRECT_WRITE_LIMIT
        ):
            return False
        for data, _ in frames:
            if len(data) > CHUNK_BYTES:  # big: the pump sends it in continuation frames
                return False
        for data, binary in frames:
            broadcast((ws,), data, text=not binary)
        return True

    return write


async def start_websocket(
    new_session: SessionFactory,
    host: str,
    port: int,
    *,
    max_frame_size: int,
    delay_between_messages: float = 0.0,
    compression: bool = False,
    http_handler: HttpHandler | None = None,
    tls: HandshakeGate | None = None,
    ping_interval: float = 0.0,
    ping_timeout: float = 30.0,
    new_foxglove: FoxgloveFactory | None = None,
    reuse_port: bool = False,
    headers: dict[str, str] | None = None,
) -> Server:
    """Serve WebSocket (``wss://`` with ``tls``, its handshakes bounded by the gate); with
    ``ping_interval`` > 0 each client is pinged that often and dropped when it does not answer
    within ``ping_timeout``. A client asking for a Foxglove subprotocol gets a ``new_foxglove``
    session, any other the rosbridge protocol. ``reuse_port``: share the port with other
    processes (SO_REUSEPORT, ``--workers``); ``headers`` go on every response (handshake and
    HTTP)."""

    async def handler(ws: ServerConnection) -> None:
        peer = ws.remote_address[0] if ws.remote_address else ""
        session: ClientSession
        if new_foxglove is not None and ws.subprotocol in SUBPROTOCOLS:
            session = new_foxglove(peer, ws.subprotocol)
        else:
            session = new_session(peer, "ws")

        async def send_frame(data: bytes, binary: bool) -> None:
            if len(data) > CHUNK_BYTES:
                view = memoryview(data)
                chunks = (view[i : i + CHUNK_BYTES] for i in range(0, len(data), CHUNK_BYTES))
                await ws.send(chunks, text=not binary)
            else:
                await ws.send(data, text=not binary)

        try:
            await run_session(session, _read(ws, session),
                              sock=ws.transport.get_extra_info("socket") if ws.transport else None,
                              send_frame=send_frame, direct=direct_writer(ws),
                              delay=delay_between_messages)
        finally:
            if session.close_reason:  # 1008: policy violation, with the reason
                await ws.close(1008, session.close_reason[:120])
            else:
                await ws.close()

    async def process_request(ws: ServerConnection, request: Request) -> Response | None:
        if request.headers.get("Upgrade", "").lower() == "websocket":
            return None
        if http_handler is not None:
            response = http_handler(ws, request)
            return await response if inspect.isawaitable(response) else response
        return ws.respond(426, "This is a WebSocket endpoint (hitrobot protocol).\n")

    def select_subprotocol(ws: ServerConnection, offered: Sequence[Subprotocol]):
        chosen = choose_subprotocol(offered, new_foxglove is not None)
        return None if chosen is None else Subprotocol(chosen)

    def process_response(ws: ServerConnection, request: Request, response: Response) -> None:
        response.headers.update(headers or {})

    return await serve(
        handler,
        host,
        port,
        max_size=max_frame_size,
        compression="deflate" if compression else None,
        process_request=process_request,
        select_subprotocol=select_subprotocol,
        process_response=process_response if headers else None,
        reuse_port=reuse_port,
        logger=QuietHttpLog(logging.getLogger("websockets.server")),
        ping_interval=ping_interval or None,
        ping_timeout=ping_timeout,
        max_queue=64,
        create_connection=ServerConnection if tls is None else _gated(tls),
    )


def _gated(gate: HandshakeGate) -> type[ServerConnection]:
    """A connection class that first runs the TLS handshake through ``gate`` and only then
    becomes a WebSocket connection (websockets' documented hook for custom connections)."""

    class TlsServerConnection(ServerConnection):
        _upgraded = False

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            # (uvloop's transports are not asyncio.Transport subclasses, but have its methods)
            address = peer_address(transport)
            if not gate.admit(address):
                transport.abort()
                return
            transport.pause_reading()  # no ClientHello byte may reach the WebSocket parser
            gate.spawn(self._handshake(transport, address))

        async def _handshake(self, transport: asyncio.Transport, address: str) -> None:
            tls_transport = await gate.upgrade(transport, self, address)
            if tls_transport is not None:
                self._upgraded = True
                super().connection_made(tls_transport)

        def connection_lost(self, exc: Exception | None) -> None:
            if self._upgraded:  # before, there is no WebSocket connection to tear down
                super().connection_lost(exc)

    return TlsServerConnection


async def _read(ws: ServerConnection, session: ClientSession) -> None:
    try:
        async for frame in ws:
            pending = session.receive(frame, binary=isinstance(frame, bytes))
            if pending is not None:  # a big op in the worker pool: the next frame waits for it
                await pending
            if not await keep_reading(session):
                return
    except ConnectionClosed:
        pass

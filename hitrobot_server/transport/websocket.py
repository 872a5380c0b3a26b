"""WebSocket transport: frames in → ClientSession.receive; its outbox → frames out.

The subprotocol a client asks for picks its session from the server's ``WireProtocols``
(session/client.py): a registered one (Foxglove's) gets its session, anything else (or nothing)
the default, rosbridge. The transport knows only the ``ClientSession`` shape.

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

from ..session.client import ClientSession, WireProtocols
from .connection import DIRECT_WRITE_LIMIT, keep_reading, limit_read, run_session
from .http import QuietHttpLog
from .tls import HandshakeGate, peer_address

log = logging.getLogger(__name__)

HttpHandler = Callable[[ServerConnection, Request], Response | Awaitable[Response] | None]

# A message bigger than this goes out as WebSocket continuation frames of this size, so that
# writing a 40 MB map is many short steps of the event loop instead of one of 100+ ms. Clients
# see one message (RFC 6455 fragmentation, reassembled by every WebSocket implementation).
CHUNK_BYTES = 1024 * 1024


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
    protocols: WireProtocols,
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
    reuse_port: bool = False,
    headers: dict[str, str] | None = None,
) -> Server:
    """Serve WebSocket (``wss://`` with ``tls``, its handshakes bounded by the gate); with
    ``ping_interval`` > 0 each client is pinged that often and dropped when it does not answer
    within ``ping_timeout``. A client gets the session of the first subprotocol it offers that
    ``protocols`` has, any other the default (rosbridge). ``reuse_port``: share the port with
    other processes (SO_REUSEPORT, ``--workers``); ``headers`` go on every response (handshake
    and HTTP)."""

    async def handler(ws: ServerConnection) -> None:
        await _serve(ws, protocols, delay_between_messages)

    def select_subprotocol(ws: ServerConnection, offered: Sequence[Subprotocol]):
        chosen = protocols.choose(offered)
        return None if chosen is None else Subprotocol(chosen)

    def process_response(ws: ServerConnection, request: Request, response: Response) -> None:
        response.headers.update(headers or {})

    return await serve(
        handler,
        host,
        port,
        max_size=max_frame_size,
        compression="deflate" if compression else None,
        process_request=_http_requests(http_handler),
        select_subprotocol=select_subprotocol,
        process_response=process_response if headers else None,
        reuse_port=reuse_port,
        logger=QuietHttpLog(logging.getLogger("websockets.server")),
        ping_interval=ping_interval or None,
        ping_timeout=ping_timeout,
        max_queue=64,
        create_connection=ServerConnection if tls is None else _gated(tls),
    )


async def _serve(ws: ServerConnection, protocols: WireProtocols, delay: float) -> None:
    """One client connection: its session, served until either side ends it."""
    peer = ws.remote_address[0] if ws.remote_address else ""
    session = protocols.open(peer, ws.subprotocol)
    limit_read(ws.transport)

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
                          send_frame=send_frame, direct=direct_writer(ws), delay=delay)
    finally:
        if session.close_reason:  # 1008: policy violation, with the reason
            await ws.close(1008, session.close_reason[:120])
        else:
            await ws.close()


def _http_requests(http_handler: HttpHandler | None):
    """Plain HTTP GETs on the WebSocket port: the handler's answer, else 426."""

    async def process_request(ws: ServerConnection, request: Request) -> Response | None:
        if request.headers.get("Upgrade", "").lower() == "websocket":
            return None
        if http_handler is not None:
            response = http_handler(ws, request)
            return await response if inspect.isawaitable(response) else response
        return ws.respond(426, "This is a WebSocket endpoint (hitrobot protocol).\n")

    return process_request


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
        count = 0
        async for frame in ws:
            pending = session.receive(frame, binary=isinstance(frame, bytes))
            if pending is not None:  # a big op in the worker pool: the next frame waits for it
                await pending
            if not await keep_reading(session, count):
                return
            count += 1
    except ConnectionClosed:
        pass

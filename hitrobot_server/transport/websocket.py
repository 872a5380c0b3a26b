"""WebSocket transport: frames in → Session.receive; Session.outbox → frames out.

Plain HTTP GETs on the same port are answered by ``http_handler`` (the web UI), as
decisions.md asks: one port for the page and the bridge.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
from collections.abc import Callable
from ssl import SSLContext

from websockets.asyncio.server import Server, ServerConnection, broadcast, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response
from websockets.protocol import State

from ..session.session import Session
from .http import QuietHttpLog

log = logging.getLogger(__name__)

SessionFactory = Callable[[str, str], Session]
HttpHandler = Callable[[ServerConnection, Request], Response | None]


# Above this many bytes in a socket's write buffer, frames wait in the outbox instead.
DIRECT_WRITE_LIMIT = 64 * 1024
# A message bigger than this goes out as WebSocket continuation frames of this size, so that
# writing a 40 MB map is many short steps of the event loop instead of one of 100+ ms. Clients
# see one message (RFC 6455 fragmentation, reassembled by every WebSocket implementation).
CHUNK_BYTES = 1024 * 1024
# Unsent bytes the kernel may hold per client socket. Beyond it frames wait in the outbox,
# where the fair scheduler still chooses among them: a slow link's pose is not stuck behind
# megabytes of map already handed to the kernel (TCP_NOTSENT_LOWAT, Linux and macOS).
NOTSENT_LOWAT = 64 * 1024
_TCP_NOTSENT_LOWAT = getattr(socket, "TCP_NOTSENT_LOWAT", None)


def limit_unsent(sock) -> None:
    """Keep the kernel's queue of unsent bytes short for this client (see NOTSENT_LOWAT)."""
    if sock is None or _TCP_NOTSENT_LOWAT is None or sock.family not in (
        socket.AF_INET, socket.AF_INET6
    ):
        return
    with contextlib.suppress(OSError):
        sock.setsockopt(socket.IPPROTO_TCP, _TCP_NOTSENT_LOWAT, NOTSENT_LOWAT)


async def wait_for_room(session: Session) -> None:
    """Backpressure: read no more input while the client's unread replies are over budget."""
    room = session.outbox.room
    if not room.is_set():
        await room.wait()


async def pump(session: Session, send_frame, delay: float) -> None:
    """Drain the session's outbox into the connection until it closes."""
    outbox = session.outbox
    try:
        while True:
            frames = await outbox.get()
            if frames is None:
                return
            for data, binary in frames:
                await send_frame(data, binary)
                if delay > 0:
                    await asyncio.sleep(delay)
            outbox.sent()
    except (ConnectionClosed, ConnectionError, OSError):
        return  # the peer went away mid-send; the reader side closes the session


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
    ssl: SSLContext | None = None,
    ping_interval: float = 0.0,
    ping_timeout: float = 30.0,
) -> Server:
    """Serve WebSocket (``wss://`` with ``ssl``); with ``ping_interval`` > 0 each client is
    pinged that often and dropped when it does not answer within ``ping_timeout``."""

    async def handler(ws: ServerConnection) -> None:
        peer = ws.remote_address[0] if ws.remote_address else ""
        session = new_session(peer, "ws")
        limit_unsent(ws.transport.get_extra_info("socket") if ws.transport else None)
        if delay_between_messages <= 0:
            session.outbox.direct = direct_writer(ws)

        async def send_frame(data: bytes, binary: bool) -> None:
            if len(data) > CHUNK_BYTES:
                view = memoryview(data)
                chunks = (view[i : i + CHUNK_BYTES] for i in range(0, len(data), CHUNK_BYTES))
                await ws.send(chunks, text=not binary)
            else:
                await ws.send(data, text=not binary)

        writer = asyncio.create_task(pump(session, send_frame, delay_between_messages))
        reader = asyncio.create_task(_read(ws, session))
        try:
            await asyncio.wait({writer, reader}, return_when=asyncio.FIRST_COMPLETED)
            if session.outbox.closed and not writer.done():  # the session asked to close: flush
                await asyncio.wait({writer}, timeout=2.0)
        finally:
            session.close()
            reader.cancel()
            if not writer.done():
                writer.cancel()
            if session.close_reason:  # 1008: policy violation, with the reason
                await ws.close(1008, session.close_reason[:120])
            else:
                await ws.close()

    def process_request(ws: ServerConnection, request: Request) -> Response | None:
        if request.headers.get("Upgrade", "").lower() == "websocket":
            return None
        if http_handler is not None:
            return http_handler(ws, request)
        return ws.respond(426, "This is a WebSocket endpoint (hitrobot protocol).\n")

    return await serve(
        handler,
        host,
        port,
        max_size=max_frame_size,
        compression="deflate" if compression else None,
        process_request=process_request,
        logger=QuietHttpLog(logging.getLogger("websockets.server")),
        ping_interval=ping_interval or None,
        ping_timeout=ping_timeout,
        max_queue=64,
        ssl=ssl,
    )


async def _read(ws: ServerConnection, session: Session) -> None:
    try:
        async for frame in ws:
            pending = session.receive(frame, binary=isinstance(frame, bytes))
            if pending is not None:  # a big op in the worker pool: the next frame waits for it
                await pending
            if session.outbox.closed:
                return
            await wait_for_room(session)
            if session.outbox.closed:
                return
    except ConnectionClosed:
        pass

"""One client connection's life, shared by the WebSocket and TCP transports: the socket's
kernel queue kept short, the session's outbox pumped into the connection, its input read under
backpressure, and the session flushed and closed when either side ends.

The transports only say how bytes leave (``send_frame``, ``direct``) and come in (``read``);
the order of the steps, the close flush and the release live here once.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any

from websockets.exceptions import ConnectionClosed

from ..session.client import ClientSession

SendFrame = Callable[[bytes, bool], Awaitable[None]]  # (data, binary)
DirectWrite = Callable[[list], bool]  # frames written now, or False: the pump sends them
Gate = Callable[[], Awaitable[None]]  # returns once the client may be sent more (its window)

# Above this many bytes in a socket's write buffer, frames wait in the outbox instead.
DIRECT_WRITE_LIMIT = 64 * 1024
# Unsent bytes the kernel may hold per client socket. Beyond it frames wait in the outbox,
# where the fair scheduler still chooses among them: a slow link's pose is not stuck behind
# megabytes of map already handed to the kernel (TCP_NOTSENT_LOWAT, Linux and macOS).
NOTSENT_LOWAT = 64 * 1024
_TCP_NOTSENT_LOWAT = getattr(socket, "TCP_NOTSENT_LOWAT", None)
# Picks the pump writes at once (the socket having room) before it lets the loop run others.
PUMP_BURST = 32
# How long a session that asked to close (an error it reports, a refusal) may flush its outbox.
CLOSE_FLUSH_SECONDS = 2.0


def limit_unsent(sock) -> None:
    """Keep the kernel's queue of unsent bytes short for this client (see NOTSENT_LOWAT)."""
    if sock is None or _TCP_NOTSENT_LOWAT is None or sock.family not in (
        socket.AF_INET, socket.AF_INET6
    ):
        return
    with contextlib.suppress(OSError):
        sock.setsockopt(socket.IPPROTO_TCP, _TCP_NOTSENT_LOWAT, NOTSENT_LOWAT)


FRAMES_PER_STEP = 32
"""Frames of one client handled before the event loop serves the others: frames already
received are handed out without a wait, so 60,000 junk frames in the socket's buffer would
otherwise be handled in one go while every other client waits."""


READ_BYTES = 16 * 1024
"""Most bytes taken from a client's socket in one read. The WebSocket library parses every
frame of one read in one go: 256 kB (asyncio's default) of 16-byte junk frames is 16,000 frames
parsed while every other client waits; 16 kB bounds that step to 1,000."""


def limit_read(transport: asyncio.BaseTransport | None) -> None:
    """Read at most :data:`READ_BYTES` at a time from this client (asyncio's socket
    transports read ``max_size`` bytes per ready socket; others are left as they are)."""
    if transport is not None and any("max_size" in vars(kind)
                                     for kind in type(transport).__mro__):
        transport.max_size = READ_BYTES  # type: ignore[attr-defined]


async def keep_reading(session: ClientSession, count: int = 0) -> bool:
    """After one input (the ``count``-th): False once the session closed; otherwise wait
    while the client's unread replies are over budget (backpressure: no more input is read
    meanwhile), and let the other clients in every :data:`FRAMES_PER_STEP` inputs."""
    if session.outbox.closed:
        return False
    room = session.outbox.room
    if not room.is_set():
        await room.wait()
    elif count % FRAMES_PER_STEP == FRAMES_PER_STEP - 1:
        await asyncio.sleep(0)
    return not session.outbox.closed


async def pump(session: ClientSession, send_frame: SendFrame, delay: float,
               gate: Gate | None = None, direct: DirectWrite | None = None) -> None:
    """Drain the session's outbox into the connection until it closes; with a ``gate``, each
    next pick waits until the client has room (what it has not read is under its window), so
    the outbox's scheduler, not the kernel's queue, decides what goes next. With ``direct``,
    a pick is written at once while the socket has room (as a publish is when nothing is
    queued), yielding to the loop every :data:`PUMP_BURST` picks; otherwise it is awaited."""
    outbox = session.outbox
    burst = 0
    try:
        while True:
            if gate is not None:
                await gate()
            frames = await outbox.get()
            if frames is None:
                return
            if direct is not None and direct(frames):
                outbox.sent()
                burst += 1
                if burst >= PUMP_BURST:
                    burst = 0
                    await asyncio.sleep(0)
                continue
            burst = 0
            for data, binary in frames:
                await send_frame(data, binary)
                if delay > 0:
                    await asyncio.sleep(delay)
            outbox.sent()
    except (ConnectionClosed, ConnectionError, OSError):
        return  # the peer went away mid-send; the reader side closes the session


async def run_session(session: ClientSession, read: Coroutine[Any, Any, None], *, sock,
                      send_frame: SendFrame, direct: DirectWrite, delay: float,
                      gate: Gate | None = None) -> None:
    """Serve one connection's session until the client or the session ends it: ``read``
    feeds the session, the outbox goes out by ``direct`` writes while the socket keeps up (not
    with a delay between messages) and by ``send_frame`` otherwise, each pick after ``gate``.
    Returns with the session closed; the caller then closes its connection."""
    limit_unsent(sock)
    if delay <= 0:
        session.outbox.attach_writer(direct)
    writer = asyncio.create_task(pump(session, send_frame, delay, gate,
                                      direct if delay <= 0 else None))
    reader = asyncio.create_task(read)
    try:
        await asyncio.wait({writer, reader}, return_when=asyncio.FIRST_COMPLETED)
        if session.outbox.closed and not writer.done():  # the session asked to close: flush
            await asyncio.wait({writer}, timeout=CLOSE_FLUSH_SECONDS)
    finally:
        session.close()
        reader.cancel()
        if not writer.done():
            writer.cancel()

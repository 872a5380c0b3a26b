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
import weakref
from collections.abc import Awaitable, Callable, Sequence

from websockets.asyncio.server import Server, ServerConnection, broadcast, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response
from websockets.protocol import State
from websockets.typing import Subprotocol

from ..session.access import Access, presented_token
from ..session.client import ClientSession, WireProtocols
from . import download
from .connection import DIRECT_WRITE_LIMIT, keep_reading, limit_read, run_session
from .control import ControlledConnection
from .download import Downloads
from .flight import FIRST_GIVE_UP, FlightWindow
from .http import QuietHttpLog
from .tls import HandshakeGate, peer_address

log = logging.getLogger(__name__)

HttpHandler = Callable[[ServerConnection, Request], Response | Awaitable[Response] | None]

# A message bigger than this goes out as WebSocket continuation frames of this size, so that
# writing a 40 MB map is many short steps of the event loop instead of one of 100+ ms. Clients
# see one message (RFC 6455 fragmentation, reassembled by every WebSocket implementation).
CHUNK_BYTES = 1024 * 1024


COUNT_EVERY = 256 * 1024
"""Bytes sent to a client not held that are counted at once, without waiting for the tick (a
flood to a client that has just shown a standing queue is held within this many bytes)."""


class WindowTick:
    """The windows' shared tick (every :data:`PERIOD` s, while bytes flow to some client, and
    :data:`LAG_MEMORY` s after: an idle client, or a server whose clients all listen to quiet
    topics, wakes nothing).

    It measures how late this event loop runs a timer: the longest lateness over the last
    :data:`LAG_MEMORY` seconds. A busy server gets to each client once per turn of its loop,
    however fast the client reads: its window must cover that turn, or the window (not the
    client) sets its rate. And it counts the bytes written to clients the window does not hold
    (``pending``): a write to them costs an addition, not the window's bookkeeping, which at
    fifty subscribers was a sixth of the CPU a delivered message takes."""

    PERIOD = 0.01
    LAG_MEMORY = 0.5

    def __init__(self, loop: asyncio.AbstractEventLoop):
        self._loop = loop
        self._timer: asyncio.TimerHandle | None = None
        self._busy = False  # bytes went out since the last tick
        self._quiet_since = 0.0
        self._due = 0.0
        self._worst = [0.0, 0.0]  # this half-memory's worst, the last one's
        self._turned = 0.0
        self.pending: set[PongWindow] = set()  # windows with bytes sent but not yet counted

    @property
    def lag(self) -> float:
        return max(self._worst)

    @property
    def running(self) -> bool:
        """The tick is due (bytes flowed to a client in the last :data:`LAG_MEMORY` s)."""
        return self._timer is not None

    def wake(self) -> None:
        """Bytes went to a client: tick (from now, if it had stopped)."""
        self._busy = True
        if self._timer is None:
            self._turned = self._quiet_since = self._loop.time()
            self._arm(self._turned)

    def count_later(self, window: PongWindow) -> None:
        """Count what ``window`` sends until the next tick then."""
        self.pending.add(window)
        self.wake()

    def _arm(self, now: float) -> None:
        self._due = now + self.PERIOD
        self._timer = self._loop.call_at(self._due, self._tick)

    def _tick(self) -> None:
        now = self._loop.time()
        late = now - self._due
        if now - self._turned >= self.LAG_MEMORY / 2:
            self._worst = [0.0, self._worst[0]]
            self._turned = now
        if late > self._worst[0]:
            self._worst[0] = late
        if self.pending:
            windows, self.pending = self.pending, set()
            for window in windows:
                window.account(now)
        if self._busy:
            self._busy = False
            self._quiet_since = now
        elif now - self._quiet_since >= self.LAG_MEMORY:  # nothing sent for a while: stop
            self._timer = None
            self._worst = [0.0, 0.0]
            return
        self._arm(now)


_TICKS: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, WindowTick] = (
    weakref.WeakKeyDictionary())


def window_tick() -> WindowTick:
    """The running loop's :class:`WindowTick` (one per loop, shared by its windows)."""
    loop = asyncio.get_running_loop()
    found = _TICKS.get(loop)
    if found is None:
        found = _TICKS[loop] = WindowTick(loop)
    return found


class PongWindow:
    """One client's :class:`~.flight.FlightWindow`, fed by WebSocket pings and their pongs.

    A ping follows the bytes the window asks it after; its pong (every WebSocket client sends
    one once it has read up to the ping) tells the window how far the client has read. Raw TCP
    has no such signal: its clients get only the kernel's short unsent queue (NOTSENT_LOWAT).
    """

    def __init__(self, ws: ServerConnection):
        self.ws = ws
        self.flight = FlightWindow()
        self._loop = asyncio.get_running_loop()
        self._tick = window_tick()
        self._room = asyncio.Event()
        self._room.set()
        self._pinging: set[asyncio.Task] = set()
        self._uncounted = 0  # bytes sent while not held, counted at the next tick

    def close(self) -> None:
        """The connection is over: nothing of it is left to count."""
        self._tick.pending.discard(self)

    @property
    def open(self) -> bool:
        """Room for more (:meth:`~.flight.FlightWindow.room`); a client not held has room
        without asking the loop's clock (this runs for every write)."""
        flight = self.flight
        return not flight.armed or flight.room(self._loop.time())

    def sent(self, nbytes: int) -> None:
        """``nbytes`` were written to the client: counted now when it is held, else at the
        next tick (:class:`WindowTick`)."""
        if not self.flight.armed:
            if not self._uncounted:
                self._tick.count_later(self)
            self._uncounted += nbytes
            if self._uncounted < COUNT_EVERY:
                return
            self._tick.pending.discard(self)
            nbytes = 0  # counted in what was uncounted
        else:
            self._tick.wake()
        self.account(self._loop.time(), nbytes)

    def account(self, now: float, nbytes: int = 0) -> None:
        """Count ``nbytes`` and what was left uncounted; ping when the window asks."""
        nbytes += self._uncounted
        self._uncounted = 0
        if self.flight.on_sent(nbytes, now):
            self._send_ping(now)
        if not self.open:
            self._room.clear()

    def _send_ping(self, now: float) -> None:
        task = self._loop.create_task(self._ping(self.flight.pinged(now)))
        self._pinging.add(task)
        task.add_done_callback(self._pinging.discard)

    async def wait_open(self) -> None:
        """Return once the client's unread bytes are under its window (or it went silent)."""
        while not self.open:
            self._room.clear()
            timer = self._loop.call_later(FIRST_GIVE_UP, self._room.set)  # to look for silence
            try:
                await self._room.wait()
            finally:
                timer.cancel()

    async def _ping(self, mark: int) -> None:
        try:
            pong = await self.ws.ping()
        except ConnectionClosed:
            return
        pong.add_done_callback(lambda done: self._ponged(mark, done))

    def _ponged(self, mark: int, done: asyncio.Future) -> None:
        if done.cancelled() or done.exception() is not None:
            return  # the connection closed first
        now = self._loop.time()
        self.flight.ponged(mark, now, self._tick.lag)
        if self.open:
            self._room.set()
        elif self.flight.stuck:  # the window shrank under what no ping covers yet
            self._send_ping(now)


def direct_writer(ws: ServerConnection, window: PongWindow | None = None):
    """Synchronous write while the socket keeps up (``broadcast`` to one connection) and the
    client's window has room."""

    def write(frames: list) -> bool:
        transport = ws.transport
        if (
            ws.protocol.state is not State.OPEN
            or transport is None
            or transport.get_write_buffer_size() > DIRECT_WRITE_LIMIT
            or (window is not None and not window.open)
        ):
            return False
        total = 0
        for data, _ in frames:
            if len(data) > CHUNK_BYTES:  # big: the pump sends it in continuation frames
                return False
            total += len(data)
        for data, binary in frames:
            broadcast((ws,), data, text=not binary)
        if window is not None:
            window.sent(total)
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
    downloads: Downloads | None = None,
    send_window: bool = False,
    access: Access | None = None,
) -> Server:
    """Serve WebSocket (``wss://`` with ``tls``, its handshakes bounded by the gate); with
    ``ping_interval`` > 0 each client is pinged that often and dropped when it does not answer
    within ``ping_timeout``. A client gets the session of the first subprotocol it offers that
    ``protocols`` has, any other the default (rosbridge). ``reuse_port``: share the port with
    other processes (SO_REUSEPORT, ``--workers``); ``headers`` go on every response (handshake
    and HTTP); ``downloads`` takes the connections that ask for a recording (streamed, not
    through websockets); ``access``: with ``--authenticate``, the token of an upgrade request
    (refused with 401 when wrong, or when a protocol without an auth op comes without one)."""

    async def handler(ws: ServerConnection) -> None:
        await _serve(ws, protocols, delay_between_messages, send_window)

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
        process_request=_http_requests(http_handler, protocols, access or Access()),
        select_subprotocol=select_subprotocol,
        process_response=process_response if headers else None,
        reuse_port=reuse_port,
        logger=QuietHttpLog(logging.getLogger("websockets.server")),
        ping_interval=ping_interval or None,
        ping_timeout=ping_timeout,
        max_queue=64,
        create_connection=_connection_class(tls, downloads),
    )


async def _serve(ws: ServerConnection, protocols: WireProtocols, delay: float,
                 send_window: bool) -> None:
    """One client connection: its session, served until either side ends it."""
    peer = ws.remote_address[0] if ws.remote_address else ""
    session = protocols.open(peer, ws.subprotocol, grant=GRANTS.pop(ws, None))
    window = PongWindow(ws) if send_window else None
    limit_read(ws.transport)

    async def send_frame(data: bytes, binary: bool) -> None:
        if len(data) > CHUNK_BYTES:
            view = memoryview(data)
            chunks = (view[i : i + CHUNK_BYTES] for i in range(0, len(data), CHUNK_BYTES))
            await ws.send(chunks, text=not binary)
        else:
            await ws.send(data, text=not binary)
        if window is not None:
            window.sent(len(data))

    try:
        await run_session(session, _read(ws, session),
                          sock=ws.transport.get_extra_info("socket") if ws.transport else None,
                          send_frame=send_frame, direct=direct_writer(ws, window), delay=delay,
                          gate=window.wait_open if window is not None else None)
    finally:
        if window is not None:
            window.close()
        if session.close_reason:  # 1008: policy violation, with the reason
            await ws.close(1008, session.close_reason[:120])
        else:
            await ws.close()


GRANTS: weakref.WeakKeyDictionary[ServerConnection, object] = weakref.WeakKeyDictionary()
"""The grant of each upgrade request's token, until its session is opened."""


def _admit(ws: ServerConnection, request: Request, protocols: WireProtocols,
           access: Access) -> Response | None:
    """The token of an upgrade request (``?token=`` or ``Authorization: Bearer``): its grant
    kept for the session, or 401. Without one a rosbridge client may still send an ``auth``
    op; a protocol without it (Foxglove) is refused. Without ``--authenticate`` a token is
    ignored."""
    if not access.enabled:
        return None
    peer = ws.remote_address[0] if ws.remote_address else ""
    token = presented_token(request.path, request.headers.get("Authorization"))
    if token is None:
        offered = [p.strip() for v in request.headers.get_all("Sec-WebSocket-Protocol")
                   for p in v.split(",")]
        if protocols.choose(offered) is None:
            return None
        found: object = ("a token is required (--authenticate): add ?token=TOKEN to the URL "
                         "or send 'Authorization: Bearer TOKEN'")
    else:
        found = access.admit(token, peer)
    if isinstance(found, str):
        response = ws.respond(401, f"{found}\n")
        response.headers["WWW-Authenticate"] = "Bearer"
        return response
    GRANTS[ws] = found
    return None


def _http_requests(http_handler: HttpHandler | None, protocols: WireProtocols, access: Access):
    """Plain HTTP GETs on the WebSocket port: the handler's answer, else 426; an upgrade's
    token checked (:func:`_admit`)."""

    async def process_request(ws: ServerConnection, request: Request) -> Response | None:
        if request.headers.get("Upgrade", "").lower() == "websocket":
            return _admit(ws, request, protocols, access)
        if http_handler is not None:
            response = http_handler(ws, request)
            return await response if inspect.isawaitable(response) else response
        return ws.respond(426, "This is a WebSocket endpoint (hitrobot protocol).\n")

    return process_request


def _connection_class(tls: HandshakeGate | None, downloads: Downloads | None
                      ) -> type[ServerConnection]:
    """Every connection counts its control frames (:mod:`.control`); then the downloads'
    split and the TLS gate, when the server has them."""
    base = ControlledConnection if downloads is None else _with_downloads(downloads)
    return base if tls is None else _gated(tls, base)


def _with_downloads(downloads: Downloads) -> type[ServerConnection]:
    """A connection class that looks at the first bytes before websockets does: a recordings
    download goes to ``downloads`` (websockets never sees it), anything else to websockets
    as if nothing had happened. Until the first bytes say which, a timer bounds the wait."""

    class SplitConnection(ControlledConnection):
        _peeked = b""
        _decided = False
        _held: asyncio.BaseTransport | None = None
        _timer: asyncio.TimerHandle | None = None

        def connection_made(self, transport: asyncio.BaseTransport) -> None:
            self._held = transport
            self._timer = asyncio.get_running_loop().call_later(
                download.HEAD_TIMEOUT, transport.abort)
            self._peek(b"")  # TLS may hand over the first bytes before the transport

        def data_received(self, data: bytes) -> None:
            if self._decided:
                return super().data_received(data)
            self._peek(data)

        def _peek(self, data: bytes) -> None:
            self._peeked += data
            claimed = download.claims(self._peeked) if self._peeked else None
            if claimed is not None and self._held is not None:
                self._decide(claimed)

        def _decide(self, claimed: bool) -> None:
            self._decided = True
            if self._timer is not None:
                self._timer.cancel()
            peeked, self._peeked = self._peeked, b""
            if claimed:
                downloads.take(self._held, peeked)  # type: ignore[arg-type]
                return
            super().connection_made(self._held)
            if peeked:
                super().data_received(peeked)

        def eof_received(self) -> bool | None:
            if not self._decided and self._held is not None:
                self._decide(False)
            return super().eof_received()

        def connection_lost(self, exc: Exception | None) -> None:
            if self._decided:
                super().connection_lost(exc)
            elif self._timer is not None:
                self._timer.cancel()

    return SplitConnection


def _gated(gate: HandshakeGate, base: type[ServerConnection]) -> type[ServerConnection]:
    """A connection class that first runs the TLS handshake through ``gate`` and only then
    becomes a WebSocket connection (websockets' documented hook for custom connections)."""

    class TlsServerConnection(base):  # type: ignore[valid-type,misc]
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

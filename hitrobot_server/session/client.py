"""What a transport knows of a client session, whatever its wire protocol, and which session a
connection gets.

A transport feeds a :class:`ClientSession` frames (``receive``) and drains its ``outbox``; it
never names a concrete session class. Which session a WebSocket connection gets is chosen by
its subprotocol in a :class:`WireProtocols` that the server fills and hands down: a new wire
protocol is its own package under ``session/`` plus one ``register`` line in server.py.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Iterable, Sequence
from typing import Any, Protocol, runtime_checkable

from ..protocol.errors import ProtocolError
from .outbox import Outbox

Pending = Awaitable[None] | None  # what receive/handle return: None, or a task to await


@runtime_checkable
class ClientSession(Protocol):
    """One client, as the transport sees it: frames in, an outbox out, a close."""

    peer: str  # the client's address, for the log
    outbox: Outbox  # what to send: the transport's pump drains it
    closed: bool
    close_reason: str  # set when the server closes the connection, sent as its close reason
    on_close: list[Callable[[Any], None]]  # run once when the session closes (the server's)

    def receive(self, data: str | bytes, binary: bool = False) -> Pending:
        """One frame (text or binary); a task when the next frame must wait for it."""
        ...

    def close(self) -> None:
        """The connection is gone: release everything the client held."""
        ...


@runtime_checkable
class StreamSession(ClientSession, Protocol):
    """A session fed by a byte stream (raw TCP) through a JSON stream decoder."""

    def handle(self, obj: object, frame: str | bytes | None = None) -> Pending:
        """One decoded op."""
        ...

    def stream_error(self, error: ProtocolError) -> None:
        """Input of the stream that could not be decoded."""
        ...


SessionFactory = Callable[..., ClientSession]
"""(peer, transport "ws"/"tcp" or the chosen subprotocol[, grant=]) → a new session."""
StreamFactory = Callable[..., StreamSession]


class WireProtocols:
    """The sessions a server speaks: the default (rosbridge, for a connection that asks for
    no registered subprotocol, and for raw TCP) and one factory per WebSocket subprotocol."""

    def __init__(self, default: StreamFactory):
        self.default = default
        self._by_subprotocol: dict[str, SessionFactory] = {}

    def register(self, subprotocols: Iterable[str], factory: SessionFactory) -> None:
        """Serve ``factory``'s session to connections that ask for one of ``subprotocols``."""
        for name in subprotocols:
            self._by_subprotocol[name] = factory

    def choose(self, offered: Sequence[str]) -> str | None:
        """The first registered subprotocol the client offers, else None (the default)."""
        for name in offered:
            if name in self._by_subprotocol:
                return name
        return None

    def open(self, peer: str, subprotocol: str | None, transport: str = "ws",
             grant: object = None) -> ClientSession:
        """The session for a new connection that agreed on ``subprotocol``; ``grant``: who
        its upgrade request's token says it is (``--authenticate``), handed to the factory
        as ``grant=`` when there is one."""
        factory = self._by_subprotocol.get(subprotocol or "")
        extra = {} if grant is None else {"grant": grant}
        if factory is None:
            return self.default(peer, transport, **extra)
        return factory(peer, subprotocol or "", **extra)

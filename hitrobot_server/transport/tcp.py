"""Raw TCP transport: a byte stream of JSON objects in, one JSON object per line out."""

from __future__ import annotations

import asyncio
import contextlib
import logging

from ..protocol.errors import ProtocolError
from ..protocol.jsonstream import JsonStreamDecoder
from ..session.client import StreamFactory, StreamSession
from .connection import DIRECT_WRITE_LIMIT, keep_reading, run_session
from .tls import HandshakeGate

log = logging.getLogger(__name__)


async def start_tcp(
    new_session: StreamFactory,
    host: str,
    port: int,
    *,
    max_frame_size: int,
    delay_between_messages: float = 0.0,
    tls: HandshakeGate | None = None,
    reuse_port: bool = False,
) -> asyncio.Server:
    """Serve the raw TCP protocol (TLS with ``tls``, its handshakes bounded by the gate);
    ``reuse_port`` shares the port with other processes (``--workers``)."""

    async def handler(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        peer = writer.get_extra_info("peername")
        address = str(peer[0]) if peer else ""
        if tls is not None and not await _handshake(tls, writer, address):
            return
        session = new_session(address, "tcp")

        async def send_frame(data: bytes, binary: bool) -> None:
            if writer.is_closing():  # uvloop raises RuntimeError on a closed transport
                raise ConnectionResetError("the client went away")
            writer.write(data + b"\n")
            await writer.drain()

        def direct(frames: list) -> bool:
            if writer.is_closing() or writer.transport.get_write_buffer_size() > DIRECT_WRITE_LIMIT:
                return False
            writer.writelines([part for data, _binary in frames for part in (data, b"\n")])
            return True

        try:
            await run_session(session, _read(reader, session, max_frame_size),
                              sock=writer.get_extra_info("socket"), send_frame=send_frame,
                              direct=direct, delay=delay_between_messages)
        finally:
            writer.close()
            with contextlib.suppress(ConnectionError, OSError):
                await writer.wait_closed()

    return await asyncio.start_server(handler, host, port, reuse_address=True,
                                      reuse_port=reuse_port)


async def _handshake(gate: HandshakeGate, writer: asyncio.StreamWriter, address: str) -> bool:
    """The TLS handshake of a new connection, within the gate's bounds; False when it was
    refused, failed or timed out (the connection is closed then)."""
    writer.transport.pause_reading()  # the ClientHello is for TLS, not the stream reader
    if not gate.admit(address):
        writer.transport.abort()
        return False
    try:
        await writer.start_tls(gate.context, ssl_handshake_timeout=gate.timeout)
    except (OSError, TimeoutError, ConnectionError, EOFError) as exc:  # ssl.SSLError is OSError
        log.debug("TLS handshake with %s failed: %s", address or "?", exc)
        writer.transport.abort()
        return False
    finally:
        gate.release(address)
    return True


async def _read(reader: asyncio.StreamReader, session: StreamSession, max_frame_size: int) -> None:
    decoder = JsonStreamDecoder(max_message_size=max_frame_size)
    try:
        while True:
            data = await reader.read(65536)
            if not data:
                return
            for item in decoder.feed(data):
                if isinstance(item, ProtocolError):
                    session.stream_error(item)
                else:
                    pending = session.handle(item)
                    if pending is not None:
                        await pending
            if not await keep_reading(session):
                return
    except (ConnectionError, OSError):
        return

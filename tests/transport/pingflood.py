"""A client that floods a WebSocket server with pings and never reads the pongs, run as its own
process (``python -m tests.transport.pingflood PORT SECONDS``) so that its work is not counted
as the server's nor slows the witness of the test; prints the bytes it handed its socket."""

from __future__ import annotations

import asyncio
import base64
import contextlib
import os
import socket
import sys
import time

PINGS_PER_WRITE = 20_000


def ping(payload: bytes = b"ping") -> bytes:
    """A client's ping frame (masked, as RFC 6455 asks of a client)."""
    mask = os.urandom(4)
    return bytes([0x89, 0x80 | len(payload)]) + mask + bytes(
        b ^ mask[i % 4] for i, b in enumerate(payload))


async def flood(port: int, seconds: float) -> int:
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    key = base64.b64encode(os.urandom(16)).decode()
    writer.write(f"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: "
                 f"Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
                 .encode())
    head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 5)
    assert head.startswith(b"HTTP/1.1 101"), head
    writer.get_extra_info("socket").setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    chunk, handed = ping() * PINGS_PER_WRITE, 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if writer.transport.get_write_buffer_size() < 4 * len(chunk):
            writer.write(chunk)  # as fast as the server takes them, a little ahead
            handed += len(chunk)
        with contextlib.suppress(asyncio.TimeoutError):
            await asyncio.wait_for(writer.drain(), 0.05)
        if writer.transport.is_closing():
            break
    writer.transport.abort()
    return handed


if __name__ == "__main__":
    print(asyncio.run(flood(int(sys.argv[1]), float(sys.argv[2]))), flush=True)

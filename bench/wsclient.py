"""The benchmarks' WebSocket client: a bare client on ``asyncio.Protocol`` that parses frame
headers only, counts frames and bytes and keeps a sample of payloads, so that the measuring
process costs as little as possible; and the helpers every scenario uses with it."""

from __future__ import annotations

import asyncio
import base64
import contextlib
import random
import time
from collections.abc import Callable

import orjson

try:
    from websockets.speedups import apply_mask
except ImportError:  # pure-Python fallback
    from websockets.utils import apply_mask

HOST = "127.0.0.1"
perf = time.perf_counter


def ws_frame(payload: bytes, opcode: int = 0x1) -> bytes:
    """One masked client frame (FIN set)."""
    n = len(payload)
    if n < 126:
        head = bytes((0x80 | opcode, 0x80 | n))
    elif n < 65536:
        head = bytes((0x80 | opcode, 0x80 | 126)) + n.to_bytes(2, "big")
    else:
        head = bytes((0x80 | opcode, 0x80 | 127)) + n.to_bytes(8, "big")
    key = random.randbytes(4)
    return head + key + apply_mask(payload, key)


class RawWs(asyncio.Protocol):
    """A bare WebSocket client: header-only frame parsing, counts, optional payload hooks.

    ``sample_every``: keep the payload of message 1, 1+k, 1+2k, ... (0 = keep none).
    ``on_message(payload, t_chunk)``: called with every payload when set (costs a copy).
    ``on_first_byte(t)``: called once, when the first byte of a data frame arrives.
    """

    extra_headers = ""  # more handshake header lines ("Name: value\r\n"), e.g. a subprotocol

    def __init__(self, *, sample_every: int = 0, on_message: Callable | None = None):
        loop = asyncio.get_running_loop()
        self.ready: asyncio.Future = loop.create_future()
        self.closed: asyncio.Future = loop.create_future()
        self.transport: asyncio.Transport | None = None
        self._hs = bytearray()
        self._opened = False
        self._buf = bytearray()
        self._parts: list[bytes] = []
        self._paused: asyncio.Future | None = None
        self.sample_every = sample_every
        self.on_message = on_message
        self.on_first_byte: Callable | None = None
        self.count = 0
        self.nbytes = 0
        self.first_rx = 0.0
        self.last_rx = 0.0
        self.samples: list[bytes] = []

    @classmethod
    async def open(cls, port: int, **kw) -> RawWs:
        loop = asyncio.get_running_loop()
        _, proto = await loop.create_connection(lambda: cls(**kw), HOST, port)
        await asyncio.wait_for(proto.ready, 10)
        return proto

    # ----------------------------------------------------------------- asyncio.Protocol
    def connection_made(self, transport) -> None:
        self.transport = transport
        key = base64.b64encode(random.randbytes(16)).decode()
        transport.write(
            (
                f"GET / HTTP/1.1\r\nHost: {HOST}\r\nUpgrade: websocket\r\n"
                f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n{self.extra_headers}"
                "Sec-WebSocket-Version: 13\r\n\r\n"
            ).encode()
        )

    def connection_lost(self, exc) -> None:
        if not self.ready.done():
            self.ready.set_exception(ConnectionError("closed during handshake"))
        if not self.closed.done():
            self.closed.set_result(None)
        if self._paused is not None and not self._paused.done():
            self._paused.set_result(None)

    def pause_writing(self) -> None:
        if self._paused is None or self._paused.done():
            self._paused = asyncio.get_running_loop().create_future()

    def resume_writing(self) -> None:
        if self._paused is not None and not self._paused.done():
            self._paused.set_result(None)

    def data_received(self, data: bytes) -> None:
        if not self._opened:
            self._hs += data
            end = self._hs.find(b"\r\n\r\n")
            if end < 0:
                return
            head, data = bytes(self._hs[:end]), bytes(self._hs[end + 4 :])
            if not head.startswith(b"HTTP/1.1 101"):
                self.ready.set_exception(ConnectionError(head.decode(errors="replace")))
                return
            self._opened = True
            self.ready.set_result(None)
            if not data:
                return
        now = perf()
        buf = self._buf
        if not buf and self.on_first_byte is not None:
            self.on_first_byte(now)
            self.on_first_byte = None
        buf += data
        n = len(buf)
        pos = 0
        while n - pos >= 2:
            b0, b1 = buf[pos], buf[pos + 1]
            length = b1 & 0x7F
            head = 2
            if length == 126:
                if n - pos < 4:
                    break
                length = int.from_bytes(buf[pos + 2 : pos + 4], "big")
                head = 4
            elif length == 127:
                if n - pos < 10:
                    break
                length = int.from_bytes(buf[pos + 2 : pos + 10], "big")
                head = 10
            if b1 & 0x80:  # servers do not mask, but be correct anyway
                head += 4
            end = pos + head + length
            if end > n:
                break
            opcode = b0 & 0x0F
            if opcode <= 0x2:
                self._message(buf, pos + head, end, b0 & 0x80, now)
            elif opcode == 0x9:  # ping -> pong
                with memoryview(buf) as mv:
                    self.transport.write(ws_frame(bytes(mv[pos + head : end]), 0xA))
            elif opcode == 0x8:
                self.transport.close()
            pos = end
        if pos:
            del buf[:pos]
        if buf and self.on_first_byte is not None:
            self.on_first_byte(now)
            self.on_first_byte = None

    def _message(self, buf: bytearray, start: int, end: int, fin: int, now: float) -> None:
        want = self.on_message is not None or self._parts or not fin
        if not want and self.sample_every:
            want = self.count % self.sample_every == 0
        payload = b""
        if want:
            with memoryview(buf) as mv:
                payload = bytes(mv[start:end])
        if not fin:
            self._parts.append(payload)
            return
        if self._parts:
            payload = b"".join(self._parts) + payload
            self._parts = []
        if self.count == 0:
            self.first_rx = now
        self.count += 1
        self.nbytes += len(payload) if payload else end - start
        self.last_rx = now
        if self.sample_every and (self.count - 1) % self.sample_every == 0:
            self.samples.append(payload)
        if self.on_message is not None:
            self.on_message(payload, now)

    # ----------------------------------------------------------------- sending
    def send(self, obj_or_bytes) -> None:
        data = obj_or_bytes if isinstance(obj_or_bytes, bytes) else orjson.dumps(obj_or_bytes)
        self.transport.write(ws_frame(data))

    def write_frame(self, frame: bytes) -> None:
        self.transport.write(frame)

    async def drain(self) -> None:
        if self._paused is not None and not self._paused.done():
            await self._paused

    def reset(self) -> None:
        self.count = self.nbytes = 0
        self.first_rx = self.last_rx = 0.0
        self.samples = []

    async def close(self) -> None:
        if self.transport is None or self.transport.is_closing():
            return
        with contextlib.suppress(Exception):
            self.transport.write(ws_frame((1000).to_bytes(2, "big"), 0x8))
            await asyncio.wait_for(asyncio.shield(self.closed), 0.5)
        self.transport.close()


async def close_all(clients) -> None:
    await asyncio.gather(*(c.close() for c in clients), return_exceptions=True)


async def barrier(client: RawWs, tag: str, timeout: float = 10.0) -> None:
    """Wait until the server has processed everything this client sent before (ops of one
    connection are handled in order): call /rosapi/get_time and wait for its response."""
    op_id = f"barrier:{tag}:{time.monotonic_ns()}".encode()
    got = asyncio.get_running_loop().create_future()
    prev = client.on_message

    def hook(payload: bytes, now: float) -> None:
        if op_id in payload and b"service_response" in payload and not got.done():
            got.set_result(None)
        if prev is not None:
            prev(payload, now)

    client.on_message = hook
    try:
        client.send({"op": "call_service", "id": op_id.decode(), "service": "/rosapi/get_time"})
        await asyncio.wait_for(got, timeout)
    finally:
        client.on_message = prev


async def warm_up(pub, src, subs, got) -> None:
    """Publish scans until every subscriber has some (``got(s)`` > 0; no reply ops needed, so
    it works for any server), let the stragglers in, then zero the counters: the measured run
    starts with every subscription flowing. Bounded: 10 s."""
    deadline, k = perf() + 10, 0
    while perf() < deadline and min(got(s) for s in subs) == 0:
        pub.write_frame(ws_frame(src.frame(k)))
        k += 1
        await asyncio.sleep(0.05)
    await asyncio.sleep(0.3)
    for s in subs:
        s.reset()

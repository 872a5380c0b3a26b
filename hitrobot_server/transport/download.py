"""Recordings downloaded straight from the file: streamed with backpressure, with ``Range``.

websockets answers a plain HTTP request with one ``Response`` whose body is a whole ``bytes``
(and its opening-handshake timeout cuts anything longer), so a 100 MB recording would be read
into memory once per downloader, and kept there by one that stops reading. So a connection
whose first bytes are ``GET /recordings/`` or ``HEAD /recordings/`` never reaches websockets:
:class:`Downloads` takes its transport, reads the request head (bounded in size and time),
and writes the file a chunk at a time, each only once the socket has taken the last
(``drain``): a stalled downloader holds one chunk and the transport's small buffer. Single
byte ranges (``Range: bytes=…``) get ``206``; anything else the whole file (``200``).
"""

from __future__ import annotations

import asyncio
import contextlib
import email.utils
import http
import http.client
import io
import logging
import os
import re
import stat
from collections.abc import Callable, Iterable
from pathlib import Path
from urllib.parse import quote

log = logging.getLogger(__name__)

PREFIXES = (b"GET /recordings/", b"HEAD /recordings/")
HEAD_LIMIT = 16 * 1024  # bytes of request line and headers
HEAD_TIMEOUT = 10.0  # seconds to send them (websockets' own opening timeout)
STALL_TIMEOUT = 120.0  # seconds a downloader may take no byte before it is dropped
CHUNK = 128 * 1024  # bytes read from the file and written at a time
WRITE_BUFFER = 64 * 1024  # the transport's buffer: write the next chunk below this
MAX_DOWNLOADS = 32  # at once, per server process
RANGE = re.compile(r"bytes=(\d*)-(\d*)")
Refusal = Callable[[str, "str | None", str], "tuple[int, str] | None"]


def claims(peeked: bytes) -> bool | None:
    """Is a connection that began with ``peeked`` a download? None: too few bytes to say."""
    for prefix in PREFIXES:
        if peeked[: len(prefix)] == prefix[: len(peeked)]:
            return True if len(peeked) >= len(prefix) else None
    return False


def byte_range(header: str, size: int) -> tuple[int, int] | None | bool:
    """The ``(first, last)`` bytes a ``Range`` header asks for; None: the whole file (no
    header, or one we do not serve, as RFC 9110 allows); False: not satisfiable."""
    match = RANGE.fullmatch(header.strip())
    if match is None:
        return None
    first, last = match.groups()
    if not first:  # the last N bytes
        if not last or int(last) == 0:
            return False
        return max(0, size - int(last)), size - 1
    start = int(first)
    end = min(int(last), size - 1) if last else size - 1
    if start >= size or end < start:
        return False
    return start, end


class Downloads:
    """The recordings downloads of one server: ``take`` a connection, ``close`` them all."""

    def __init__(self, resolve: Callable[[str], Path | None],
                 headers: Iterable[tuple[str, str]] = (), refusal: Refusal | None = None):
        """``resolve``: the file a request path names, None for a 404 (it checks that the
        file lies directly in the recordings folder); ``headers`` go on every response;
        ``refusal``: (path, Authorization header, peer) → None, or (401 or 403, why)."""
        self.resolve = resolve
        self.headers = list(headers)
        self.refusal = refusal
        self._tasks: set[asyncio.Task] = set()

    def take(self, transport: asyncio.Transport, peeked: bytes) -> None:
        """Serve the connection on ``transport``, whose first bytes were ``peeked``."""
        loop = asyncio.get_running_loop()
        reader = asyncio.StreamReader(limit=HEAD_LIMIT)
        protocol = asyncio.StreamReaderProtocol(reader)
        transport.set_protocol(protocol)
        protocol.connection_made(transport)
        transport.set_write_buffer_limits(high=WRITE_BUFFER)
        reader.feed_data(peeked)
        writer = asyncio.StreamWriter(transport, protocol, reader, loop)
        task = loop.create_task(self._serve(reader, writer))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    def close(self) -> None:
        for task in list(self._tasks):
            task.cancel()

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        answered = False
        try:
            try:
                head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), HEAD_TIMEOUT)
                await self._answer(head, writer)
            except (ValueError, http.client.HTTPException):
                await self._send(writer, 400, "Bad request\n")
            answered = True
        except (TimeoutError, asyncio.IncompleteReadError, asyncio.LimitOverrunError,
                ConnectionError):
            pass  # too slow, too big, or gone: nothing more to say
        finally:
            if answered:
                writer.close()
            else:  # a stalled downloader's buffer is dropped, not kept until it reads
                writer.transport.abort()

    async def _answer(self, head: bytes, writer: asyncio.StreamWriter) -> None:
        line, _, rest = head.partition(b"\r\n")
        method, target, version = line.decode("latin-1").split(" ")
        if not version.startswith("HTTP/1."):
            raise ValueError(version)
        headers = http.client.parse_headers(io.BytesIO(rest))
        refused = None if self.refusal is None else self.refusal(
            target, headers.get("Authorization"), _peer(writer))
        if refused is not None:
            extra = [("WWW-Authenticate", "Bearer")] if refused[0] == 401 else []
            return await self._send(writer, refused[0], refused[1] + "\n", extra,
                                    head=method == "HEAD")
        if len(self._tasks) > MAX_DOWNLOADS:
            return await self._send(writer, 503, "Too many downloads at once; try again\n")
        path = self.resolve(target)
        fd = _open(path) if path is not None else None
        if fd is None:
            return await self._send(writer, 404, "Not found\n", head=method == "HEAD")
        try:
            await self._file(fd, path.name, method, headers.get("Range", ""), writer)
        finally:
            os.close(fd)

    async def _file(self, fd: int, name: str, method: str, range_header: str,
                    writer: asyncio.StreamWriter) -> None:
        size = os.fstat(fd).st_size
        wanted = byte_range(range_header, size) if range_header else None
        if wanted is False:
            return await self._send(writer, 416, "Range not satisfiable\n",
                                    [("Content-Range", f"bytes */{size}")])
        first, last = wanted or (0, size - 1)
        extra = [("Content-Type", "application/octet-stream"), ("Cache-Control", "no-store"),
                 ("Accept-Ranges", "bytes"),
                 ("Content-Disposition", f"attachment; filename*=UTF-8''{quote(name)}")]
        if wanted:
            extra.append(("Content-Range", f"bytes {first}-{last}/{size}"))
        writer.write(self._head(206 if wanted else 200, extra, last - first + 1))
        if method == "HEAD":
            return await _drain(writer)
        offset = first
        while offset <= last:
            data = await asyncio.to_thread(os.pread, fd, min(CHUNK, last + 1 - offset), offset)
            if not data:  # the file shrank: the client sees a short body and the close
                return
            writer.write(data)
            offset += len(data)
            await _drain(writer)

    async def _send(self, writer: asyncio.StreamWriter, status: int, text: str,
                    extra: list[tuple[str, str]] | None = None, head: bool = False) -> None:
        body = text.encode()
        writer.write(self._head(status, [("Content-Type", "text/plain; charset=utf-8"),
                                         *(extra or [])], len(body)))
        if not head:
            writer.write(body)
        await _drain(writer)

    def _head(self, status: int, extra: list[tuple[str, str]], length: int) -> bytes:
        code = http.HTTPStatus(status)
        lines = [f"HTTP/1.1 {code.value} {code.phrase}",
                 f"Date: {email.utils.formatdate(usegmt=True)}", "Connection: close",
                 "X-Content-Type-Options: nosniff", "Referrer-Policy: no-referrer",
                 *(f"{k}: {v}" for k, v in [*extra, *self.headers]),
                 f"Content-Length: {length}"]
        return ("\r\n".join(lines) + "\r\n\r\n").encode("latin-1")


def _peer(writer: asyncio.StreamWriter) -> str:
    peer = writer.get_extra_info("peername")
    return str(peer[0]) if peer else ""


async def _drain(writer: asyncio.StreamWriter) -> None:
    """Wait until the socket took what was written (the backpressure), bounded in time."""
    await asyncio.wait_for(writer.drain(), STALL_TIMEOUT)


def _open(path: Path) -> int | None:
    """The regular file at ``path``, opened without following a symlink (None otherwise)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
    except OSError:
        return None
    with contextlib.suppress(OSError):
        if stat.S_ISREG(os.fstat(fd).st_mode):
            return fd
    os.close(fd)
    return None

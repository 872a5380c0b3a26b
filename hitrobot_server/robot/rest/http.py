"""A thin aiohttp session for one robot: timeouts, and one request in flight per resource.

Every request has a timeout. Requests to the same path (the *resource*) are serialised, and a
GET identical to one already in flight is not sent again: the second caller shares the first
one's reply (single flight). A slow robot therefore sees at most one request per resource at a
time however many workers poll it. Transport failures (refused, reset, timed out) raise
:class:`TransportError`; any HTTP status comes back as a :class:`Reply` for the caller to judge.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import aiohttp
import orjson

CONNECT_TIMEOUT = 2.0
CHUNK = 64 * 1024


class BodyTooLarge(Exception):
    """The robot's answer is bigger than its endpoint's bound (or declares an absurd size)."""


@dataclass(frozen=True, slots=True)
class Bound:
    """How much of an answer to read: at most ``most`` bytes; with ``sized``, the first
    ``head`` bytes are read, then ``sized(head_bytes)`` says how many the body has (it may
    raise ``ValueError`` for an absurd size) and nothing past that is read."""

    most: int
    head: int = 0
    sized: Callable[[bytes], int] | None = None


class TransportError(Exception):
    """The robot could not be reached or did not answer in time."""

    def __init__(self, message: str, timed_out: bool = False):
        super().__init__(message)
        self.timed_out = timed_out


@dataclass(frozen=True, slots=True)
class Reply:
    status: int
    content_type: str
    body: bytes

    @property
    def ok(self) -> bool:
        return 200 <= self.status < 300

    def json(self) -> Any:
        """The body as JSON (``None`` for an empty body); ``ValueError`` if it is not JSON."""
        if not self.body.strip():
            return None
        return orjson.loads(self.body)

    def text(self, limit: int = 200) -> str:
        text = self.body[:limit].decode("utf-8", "replace").strip()
        return text + ("…" if len(self.body) > limit else "")


class RestHttp:
    """HTTP to ``base_url`` (``http://host:port``) from one event loop."""

    def __init__(self, base_url: str, connect_timeout: float = CONNECT_TIMEOUT):
        self.base_url = base_url.rstrip("/")
        self._connect_timeout = connect_timeout
        self._session: aiohttp.ClientSession | None = None
        self._locks: dict[str, asyncio.Lock] = {}
        self._inflight: dict[tuple, asyncio.Task[Reply]] = {}

    def _open(self) -> aiohttp.ClientSession:
        if self._session is None or self._session.closed:
            self._session = aiohttp.ClientSession(
                connector=aiohttp.TCPConnector(limit=16, enable_cleanup_closed=False),
                json_serialize=lambda v: orjson.dumps(v).decode(),
            )
        return self._session

    async def reset(self) -> None:
        """Drop pooled connections (after the robot went away, they are stale)."""
        session, self._session = self._session, None
        if session is not None:
            with contextlib.suppress(Exception):
                await session.close()

    async def close(self) -> None:
        for task in list(self._inflight.values()):
            task.cancel()
        self._inflight.clear()
        await self.reset()

    async def request(
        self,
        method: str,
        path: str,
        *,
        timeout: float,
        params: Mapping[str, Any] | None = None,
        json: Any = None,
        data: bytes | None = None,
        bound: Bound,
    ) -> Reply:
        """Send one request; identical concurrent GETs share one round trip."""
        query = tuple(sorted((k, str(v)) for k, v in (params or {}).items()))
        if method != "GET":
            return await self._send(method, path, query, json, data, timeout, bound)
        key = (path, query)
        task = self._inflight.get(key)
        if task is None:
            task = asyncio.ensure_future(
                self._send(method, path, query, None, None, timeout, bound))
            self._inflight[key] = task
            task.add_done_callback(lambda t, k=key: self._finished(k, t))
        try:
            return await asyncio.shield(task)
        finally:
            del task  # else the task's exception, its traceback and this frame form a cycle

    def _finished(self, key: tuple, task: asyncio.Task) -> None:
        if self._inflight.get(key) is task:
            del self._inflight[key]
        if not task.cancelled():
            task.exception()  # retrieved here so an unshared failure is never "unretrieved"

    async def _send(self, method: str, path: str, query: tuple, json: Any, data: bytes | None,
                    timeout: float, bound: Bound) -> Reply:
        lock = self._locks.setdefault(path, asyncio.Lock())
        async with lock:
            session = self._open()
            limits = aiohttp.ClientTimeout(total=timeout,
                                           sock_connect=min(timeout, self._connect_timeout))
            kwargs: dict[str, Any] = {"timeout": limits}
            if query:
                kwargs["params"] = list(query)
            if json is not None:
                kwargs["json"] = json
            if data is not None:
                kwargs["data"] = data
                kwargs["headers"] = {"Content-Type": "application/octet-stream"}
            try:
                async with session.request(method, self.base_url + path, **kwargs) as resp:
                    try:
                        body = await read_bounded(resp, bound)
                    except BodyTooLarge:
                        resp.close()  # the rest is never read: drop the connection
                        raise
                    if not resp.content.is_eof():
                        resp.close()  # a map's bytes past what its header declares
                    return Reply(resp.status, resp.content_type, body)
            except TimeoutError:
                raise TransportError(f"no answer within {timeout:g} s", timed_out=True) from None
            except (aiohttp.ClientConnectionError, aiohttp.ClientPayloadError, OSError) as exc:
                raise TransportError(str(exc) or type(exc).__name__) from None


async def read_bounded(resp: aiohttp.ClientResponse, bound: Bound) -> bytes:
    """The body of ``resp``, read chunk by chunk and never past ``bound``."""
    stated = resp.content_length
    if stated is not None and stated > bound.most:
        raise BodyTooLarge(f"the answer states {stated} bytes, over the bound of {bound.most}")
    most = bound.most
    if bound.sized is None:
        body = await _read(resp.content, most + 1)
        if len(body) <= most:
            return body
        del body  # the exception's frames must not keep the bytes alive
        raise BodyTooLarge(f"the answer runs past the bound of {most} bytes")
    head = await _read(resp.content, bound.head)
    try:
        most = min(most, bound.sized(head))
    except ValueError as exc:
        raise BodyTooLarge(str(exc)) from None
    if len(head) >= most:  # a header-only answer, or no more than it declares
        return head[:most]
    return head + await _read(resp.content, most - len(head))


async def _read(content: aiohttp.StreamReader, size: int) -> bytes:
    """Up to ``size`` bytes (fewer when the body ends first), joined once at the end."""
    chunks: list[bytes] = []
    got = 0
    try:
        while got < size:
            chunk = await content.read(min(CHUNK, size - got))
            if not chunk:
                break
            chunks.append(chunk)
            got += len(chunk)
    except BaseException:
        chunks.clear()  # a timeout's traceback must not keep what was read
        raise
    return b"".join(chunks)

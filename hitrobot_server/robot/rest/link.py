"""``RestLink``: the connection to one Slamware robot and the HTTP calls every capability
adapter of :mod:`.client` makes through it.

Connection handling follows ``slamware_ros_sdk_server_node``: a background task connects
(``GET capabilities`` until the core agent is enabled) and, whenever the robot is lost, waits
``reconn_wait_ms`` and tries again, forever. While it is not connected :attr:`connected` is
False and every call raises :class:`NotConnectedError` without touching the network.

The robot counts as lost when a connection fails (refused, reset, unreachable) or when nothing
has answered for twice the request timeout. HTTP errors (400, 404 where it is not a normal
answer, 500) and ``false`` replies from setters become :class:`BackendError` with the method,
path and the robot's own text. A read (``GET``) whose answer cannot be used (an HTTP error, not
JSON, a shape we cannot read, a body over its bound of :mod:`.limits`) is also remembered in
:attr:`RestLink.troubles`, which ``/diagnostics_agg`` and ``/healthz`` report until the
robot answers well again. Bodies over :data:`.limits.PARSE_INLINE` are parsed in a thread.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from collections.abc import Callable
from typing import Any, TypeVar
from urllib.parse import urlsplit

from ..backend import BackendError, Link, NotConnectedError
from ..model import ActionInfo, Pose2D
from . import limits, mapformat, paths, shapes
from .http import BodyTooLarge, Bound, Reply, RestHttp, TransportError
from .trouble import Troubles

log = logging.getLogger(__name__)

T = TypeVar("T")

TELEMETRY_TIMEOUT = 1.5
"""Seconds for state reads (pose, scan, status): real clients use 1.5-2 s."""
CONTROL_TIMEOUT = 8.0
"""Seconds for commands and configuration."""
BULK_TIMEOUT = 30.0
"""Seconds for maps and stcm files, which can be large."""


class RestLink(Link):
    """The robot at ``url`` (``http://192.168.11.1:1448``): reachable or not, and the shared
    requests (timeouts, error wording) of every capability adapter."""

    def __init__(
        self,
        url: str,
        reconn_wait_ms: int = 3000,
        *,
        timeout: float = TELEMETRY_TIMEOUT,
        control_timeout: float = CONTROL_TIMEOUT,
        bulk_timeout: float = BULK_TIMEOUT,
    ):
        parts = urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.netloc:
            raise ValueError(f"not a Slamware REST URL: {url!r} (expected http://HOST:PORT)")
        if reconn_wait_ms <= 0 or timeout <= 0 or control_timeout <= 0 or bulk_timeout <= 0:
            raise ValueError("reconn_wait_ms and the timeouts must be positive")
        self.url = f"{parts.scheme}://{parts.netloc}{parts.path.rstrip('/')}"
        self.reconn_wait = reconn_wait_ms / 1000.0
        self.timeout = timeout
        self.control_timeout = control_timeout
        self.bulk_timeout = bulk_timeout
        self._http = RestHttp(self.url)
        self._connected = False
        self._task: asyncio.Task[None] | None = None
        self._lost: asyncio.Event | None = None
        self._last_ok = 0.0
        self.troubles = Troubles()

    @property
    def trouble(self) -> str:
        return self.troubles.reason

    # --- connection --------------------------------------------------------------------------

    @property
    def connected(self) -> bool:
        return self._connected

    async def start(self) -> None:
        if self._task is None or self._task.done():
            self._lost = asyncio.Event()
            self._task = asyncio.get_running_loop().create_task(
                self._keep_connected(), name="slamware-rest-connect")

    async def stop(self) -> None:
        task, self._task = self._task, None
        self._connected = False
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        await self._http.close()

    async def _keep_connected(self) -> None:
        warned = False
        while True:
            try:
                ready, why = await self._probe()
            except TransportError as exc:
                ready, why = False, str(exc)
            if ready:
                warned = False
                self._last_ok = time.monotonic()
                self._connected = True
                self.troubles.clear()
                log.info("connected to the Slamware robot at %s", self.url)
                assert self._lost is not None
                await self._lost.wait()
                self._lost.clear()
                await self._http.reset()
                warned = True  # the loss was logged; stay quiet until the robot is back
            elif not warned:
                log.warning("Slamware robot at %s not reachable (%s); retrying every %d ms",
                            self.url, why, round(self.reconn_wait * 1000))
                warned = True
            await asyncio.sleep(self.reconn_wait)

    async def _probe(self) -> tuple[bool, str]:
        """Poll ``capabilities`` as the manual asks; a robot without it is probed with
        ``robot/info``."""
        try:
            reply = await self._http.request("GET", paths.CAPABILITIES, timeout=self.timeout,
                                             bound=bound_of(paths.CAPABILITIES))
            if reply.status == 404:
                reply = await self._http.request("GET", paths.ROBOT_INFO, timeout=self.timeout,
                                                 bound=bound_of(paths.ROBOT_INFO))
                return reply.ok, f"robot/info answered HTTP {reply.status}"
        except BodyTooLarge as exc:
            return False, str(exc)
        if not reply.ok:
            return False, f"capabilities answered HTTP {reply.status}"
        try:
            ready = shapes.core_ready(reply.json())
        except ValueError as exc:
            return False, f"capabilities: {exc}"
        return ready, "the core agent is still starting"

    def lose(self, why: str) -> None:
        """Treat the robot as gone (reconnecting every ``reconn_wait_ms``)."""
        if self._connected:
            self._connected = False
            log.warning("lost the Slamware robot at %s (%s); reconnecting every %d ms",
                        self.url, why, round(self.reconn_wait * 1000))
            if self._lost is not None:
                self._lost.set()

    def require_connection(self) -> None:
        """Raise :class:`NotConnectedError` while the robot is not connected."""
        if not self._connected:
            raise NotConnectedError(f"the robot at {self.url} is not connected")

    # --- requests ----------------------------------------------------------------------------

    async def request(self, method: str, path: str, *, timeout: float | None = None,
                      params: dict[str, Any] | None = None, json: Any = None,
                      data: bytes | None = None) -> Reply:
        """One HTTP call; a transport failure loses the robot (or, for a lone timeout, is a
        :class:`BackendError`)."""
        self.require_connection()
        try:
            reply = await self._http.request(method, path, timeout=timeout or self.timeout,
                                             params=params, json=json, data=data,
                                             bound=bound_of(path))
        except BodyTooLarge as exc:
            text, timed_out = str(exc), None
        except TransportError as exc:
            text, timed_out = str(exc), exc.timed_out
        else:
            self._last_ok = time.monotonic()
            return reply
        # raised out here from words only, so the error carries neither the failure's
        # frames nor what they had read
        raise self._failed(method, path, text, timed_out)

    def _failed(self, method: str, path: str, text: str,
                timed_out: bool | None) -> BackendError:
        """The error for a body over its bound (``timed_out`` None) or a transport failure."""
        if timed_out is None:
            self._last_ok = time.monotonic()  # it answered, too much
            return self.refused(method, path, text)
        silent = time.monotonic() - self._last_ok
        if not timed_out or silent > 2.0 * self.timeout:
            self.lose(f"{method} {path}: {text}")
        if not self._connected:
            return NotConnectedError(f"{method} {path}: {text}")
        return BackendError(f"{method} {path}: {text}")

    async def json(self, method: str, path: str, *, missing_ok: bool = False,
                   timeout: float | None = None, params: dict[str, Any] | None = None,
                   json: Any = None) -> Any:
        """The JSON answer; ``None`` for a 404 when ``missing_ok``."""
        reply = await self.request(method, path, timeout=timeout, params=params, json=json)
        if reply.status == 404 and missing_ok:
            self.answered(method, path)
            return None
        if not reply.ok:
            raise self.refused(method, path, http_error(reply))
        try:
            value = await parsed(reply, reply.json)
        except ValueError:
            raise self.refused(method, path, f"not JSON: {reply.text()}") from None
        self.answered(method, path)
        return value

    def refused(self, method: str, path: str, why: str) -> BackendError:
        """The error for an answer that cannot be used; a read's is remembered as trouble."""
        text = f"{method} {path}: {why}"
        if method == "GET":
            self.troubles.bad(path, text)
        return BackendError(text)

    def answered(self, method: str, path: str) -> None:
        """A read answered well: its endpoint is no trouble any more."""
        if method == "GET":
            self.troubles.good(path)

    async def get(self, path: str, convert: Callable[[Any], T], *,
                  missing_ok: bool = False, timeout: float | None = None) -> T | None:
        """``GET path`` converted; ``None`` for a 404 when ``missing_ok``."""
        value = await self.json("GET", path, missing_ok=missing_ok, timeout=timeout)
        if value is None and missing_ok:
            return None
        try:
            return convert(value)
        except (ValueError, TypeError, KeyError) as exc:
            raise self.refused("GET", path, f"unexpected answer: {exc}") from None

    async def boolean(self, path: str) -> bool:
        return bool(await self.get(path, lambda v: shapes.boolean(v, path)))

    async def command(self, method: str, path: str, json: Any = None, *,
                      data: bytes | None = None, timeout: float | None = None) -> bool | None:
        """A setter: HTTP errors raise; a bare ``false`` raises; ``true`` or no body pass.
        Returns the boolean answer (``None`` without one)."""
        reply = await self.request(method, path, json=json, data=data,
                                   timeout=timeout or self.control_timeout)
        if not reply.ok:
            raise failed(method, path, reply)
        answer = answer_of(reply)
        if answer is False:
            raise BackendError(f"{method} {path}: the robot answered false")
        return answer

    async def removal(self, method: str, path: str, json: Any = None,
                      absent: tuple[int, ...] = (404,)) -> bool:
        """A call that removes or changes something that may not exist: False when the robot
        answers one of ``absent`` or a bare ``false``."""
        reply = await self.request(method, path, json=json, timeout=self.control_timeout)
        if reply.status in absent:
            return False
        if not reply.ok:
            raise failed(method, path, reply)
        return answer_of(reply) is not False

    async def start_action(self, body: dict) -> ActionInfo:
        """``POST actions``: the started action."""
        name = body["action_name"].removeprefix(shapes.ACTION_PREFIX)
        reply = await self.request("POST", paths.ACTIONS, json=body,
                                   timeout=self.control_timeout)
        if not reply.ok:
            text = reply.text()
            raise BackendError(f"the robot could not start {name} (HTTP {reply.status}"
                               + (f": {text})" if text else ")"))
        try:
            return shapes.action_from(reply.json())
        except ValueError as exc:
            raise BackendError(f"POST {paths.ACTIONS} ({name}): unexpected answer: {exc}") \
                from None


def bound_of(path: str) -> Bound:
    """How much of ``path``'s answer is read (:mod:`.limits`)."""
    if path == paths.EXPLORE_MAP:
        return Bound(limits.body_limit(path), mapformat.HEADER_SIZE, mapformat.declared_size)
    return Bound(limits.body_limit(path))


async def parsed(reply: Reply, parse: Callable[[], T]) -> T:
    """``parse()`` of ``reply``'s body: in a thread when the body is big."""
    if len(reply.body) > limits.PARSE_INLINE:
        return await asyncio.to_thread(parse)
    return parse()


def failed(method: str, path: str, reply: Reply) -> BackendError:
    """An HTTP error answer, worded with the method, path and the robot's own text."""
    return BackendError(f"{method} {path}: {http_error(reply)}")


def http_error(reply: Reply) -> str:
    text = reply.text()
    return f"HTTP {reply.status}" + (f": {text}" if text else "")


def converted(path: str, convert: Callable[[Any], T], value: Any) -> T:
    """``convert(value)``; a shape it refuses is a :class:`BackendError`."""
    try:
        return convert(value)
    except (ValueError, TypeError, KeyError) as exc:
        raise BackendError(f"{path}: unexpected answer: {exc}") from None


def answer_of(reply: Reply) -> bool | None:
    """A setter's bare boolean; anything else (no body, an object) reads as ``None``."""
    try:
        value = reply.json()
    except ValueError:
        return None
    return value if isinstance(value, bool) else None


def finite_pose(pose: Pose2D) -> None:
    if not all(math.isfinite(v) for v in (pose.x, pose.y, pose.yaw)):
        raise BackendError("pose must be finite")

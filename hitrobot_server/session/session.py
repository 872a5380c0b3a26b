"""One connected client: parses its ops, keeps its state, and talks to the bus.

The session owns no socket. A transport feeds it frames (``receive``) or decoded objects
(``handle``) and drains ``outbox``; that is all a transport does. Both return ``None`` once the
op is done, or a task when a big op went to the worker pool (session/offload.py): the transport
awaits it before feeding the next frame, so one client's ops still run in the order sent.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import time
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any

import cbor2

from ..bus.core import Bus
from ..bus.errors import BusError
from ..bus.topics import Origin
from ..config import Settings
from ..protocol import auth, bulk, ops, png
from ..protocol.errors import ProtocolError, status_op
from ..protocol.fragment import Defragmenter
from ..protocol.status import set_level, should_send
from ..types import jsoncodec
from ..types.convert import ConversionError
from . import offload
from .actions import ActionOps
from .outbox import Frames, Outbox
from .publish import PublishOps
from .services import ServiceOps
from .subscribe import SubscribeOps
from .wire import json_frames

log = logging.getLogger(__name__)
Pending = Awaitable[None] | None  # what receive/handle return: None, or a task to await
_client_ids = itertools.count(1)


class Session:
    """Per-client protocol state machine (transport-independent)."""

    def __init__(self, bus: Bus, settings: Settings, *, peer: str = "", transport: str = "ws"):
        self.bus = bus
        self.settings = settings
        self.types = bus.types
        self.peer = peer
        self.transport = transport
        self.client_id = next(_client_ids)
        self.node = f"/hitrobot_client_{self.client_id}"
        self.outbox = Outbox(settings.send_buffer_limit)
        self.status_level = settings.status_level
        self.authenticated = not settings.authenticate
        self.auth_level: str | None = None
        self.closed = False
        self.frame: str | bytes | None = None  # the text of the op being handled, if known
        self._defrag = Defragmenter(
            fragment_timeout=settings.fragment_timeout, max_bytes=settings.max_frame_size
        )
        self._tasks: set[asyncio.Task] = set()
        self.on_close: list[Callable[[Session], None]] = []
        self.topic_names: dict[str, str] = {}  # accepted topic spellings → canonical names
        self.publishing = PublishOps(self)
        self.subscriptions = SubscribeOps(self)
        self.service_ops = ServiceOps(self)
        self.action_ops = ActionOps(self)
        self._handlers: dict[str, Callable[[dict], Pending]] = {
            "fragment": self._op_fragment,
            "png": self._op_png,
            "set_level": self._op_set_level,
            "auth": self._op_auth,
            "advertise": self.publishing.advertise,
            "unadvertise": self.publishing.unadvertise,
            "publish": self.publishing.publish,
            "subscribe": self.subscriptions.subscribe,
            "unsubscribe": self.subscriptions.unsubscribe,
            "call_service": self.service_ops.call_service,
            "advertise_service": self.service_ops.advertise_service,
            "unadvertise_service": self.service_ops.unadvertise_service,
            "service_response": self.service_ops.service_response,
            "advertise_action": self.action_ops.advertise_action,
            "unadvertise_action": self.action_ops.unadvertise_action,
            "send_action_goal": self.action_ops.send_action_goal,
            "cancel_action_goal": self.action_ops.cancel_action_goal,
            "action_feedback": self.action_ops.action_feedback,
            "action_result": self.action_ops.action_result,
        }
        self.origin = Origin(self.node)
        bus.register_node(self.node)
        log.info("client %s connected from %s over %s", self.node, peer or "?", transport)

    # ------------------------------------------------------------------ input
    def receive(self, data: str | bytes, binary: bool = False) -> Pending:
        """One WebSocket frame (text JSON, or binary CBOR) or a re-assembled text."""
        if len(data) >= offload.OFFLOAD_BYTES:
            return self._offload(bulk.decode_cbor if binary else bulk.decode_json, data)
        try:
            obj = cbor2.loads(data) if binary else jsoncodec.loads(data)
        except Exception as exc:  # orjson.JSONDecodeError, cbor2.CBORDecodeError
            kind = "CBOR" if binary else "JSON"
            self.status("error", f"invalid {kind}: {exc}", None)
            return None
        if binary:
            return self.handle(obj)
        self.frame = data  # a publish may send this text on as it is
        try:
            return self.handle(obj)
        finally:
            self.frame = None

    def _offload(self, decode: Callable[[Any], object], data: object, op_id: Any = None) -> Pending:
        """Decode a big frame (or png payload) in the worker pool, then handle it here."""

        async def run() -> None:
            try:
                obj = await offload.run(decode, data)
            except bulk.PngError as exc:
                self.status("error", f"png: field 'data' is not a valid PNG payload: {exc}", op_id)
                return
            except bulk.DecodeError as exc:
                kind = "CBOR" if decode is bulk.decode_cbor else "JSON"
                self.status("error", f"invalid {kind}: {exc}", exc.id)
                return
            except Exception as exc:  # the pool broke (a worker was killed): say so, go on
                log.exception("client %s: decoding a big op failed", self.node)
                self.status("error", f"internal error: {exc}", op_id)
                return
            more = self.handle(obj)
            if more is not None:
                await more

        return self.spawn(run())

    def handle(self, obj: object) -> Pending:
        """Run one decoded op; every failure becomes a status message, never an exception."""
        op_id = obj.get("id") if isinstance(obj, dict) else None
        try:
            msg = ops.parse_message(obj)
            op_id = msg.get("id")
            if not self.authenticated and msg["op"] != "auth":
                self._reject_unauthenticated(msg)
                return
            ops.validate_op(msg)
            return self._handlers[msg["op"]](msg)
        except ProtocolError as exc:
            self.status(exc.level, exc.msg, exc.id if exc.id is not None else op_id)
        except (BusError, ConversionError) as exc:
            op = obj.get("op") if isinstance(obj, dict) else "?"
            self.status("error", f"{op}: {exc}", op_id)
        except Exception as exc:
            log.exception("client %s: op failed", self.node)
            self.status("error", f"internal error: {exc}", op_id)
        return None

    def _op_fragment(self, msg: dict) -> Pending:
        text = self._defrag.add(msg, time.monotonic())
        return None if text is None else self.receive(text)

    def _op_png(self, msg: dict) -> Pending:
        if len(msg["data"]) >= offload.OFFLOAD_BYTES:
            return self._offload(bulk.decode_png, msg["data"], msg.get("id"))
        try:
            text = png.decode(msg["data"])
        except Exception as exc:
            raise ProtocolError(
                f"png: field 'data' is not a valid PNG payload: {exc}", msg.get("id")
            ) from None
        return self.receive(text)

    def _op_set_level(self, msg: dict) -> None:
        self.status_level = set_level(msg)
        self.status("info", f"status level set to {self.status_level}", msg.get("id"))

    def _op_auth(self, msg: dict) -> None:
        if not self.settings.authenticate:
            self.status("info", "auth: authentication is not enabled; ignored", msg.get("id"))
            return
        if self.authenticated:
            self.status("warning", "auth: already authenticated", msg.get("id"))
            return
        if auth.verify(msg, self.settings.auth_secret or "", time.time()):
            self.authenticated = True
            self.auth_level = msg.get("level")
            self.origin = Origin(self.node, self.auth_level)
            self.status("info", f"authenticated at level {self.auth_level!r}", msg.get("id"))
        else:
            self.status("error", "auth: authentication failed; closing", msg.get("id"))
            self.close_connection()

    def _reject_unauthenticated(self, msg: dict) -> None:
        self.status("error", f"{msg['op']}: not authenticated; send 'auth' first", msg.get("id"))
        self.close_connection()

    # ------------------------------------------------------------------ output
    def send(
        self, obj: dict, *, fragment_size: int | None = None, compression: str = "none"
    ) -> None:
        """Queue a reply op; replies are never dropped by the send buffer."""
        size = fragment_size or self.settings.max_message_size
        self.outbox.put(json_frames(obj, size, compression))

    def send_frames(self, frames: Frames, droppable: bool, size: int | None = None) -> None:
        self.outbox.put(frames, droppable, size)

    def status(self, level: str, msg: str, op_id: Any = None) -> None:
        if level == "error":
            log.info("client %s: %s", self.node, msg)
        if not should_send(self.status_level, level):
            return
        self.outbox.put(json_frames(status_op(level, msg, op_id)))

    def spawn(self, coro: Coroutine[Any, Any, Any]) -> asyncio.Task:
        """Run a coroutine tied to this client; it is cancelled when the client goes."""
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    # ------------------------------------------------------------------ lifecycle
    def close_connection(self) -> None:
        """Ask the transport to close after flushing what is queued."""
        self.outbox.close()

    def close(self) -> None:
        """The connection is gone: release everything this client held on the bus."""
        if self.closed:
            return
        self.closed = True
        self.outbox.close()
        self.subscriptions.close()
        self.service_ops.close()
        self.action_ops.close()
        self.publishing.close()
        for task in list(self._tasks):
            task.cancel()
        self.bus.remove_owner(self)
        self.bus.unregister_node(self.node)
        for callback in self.on_close:
            callback(self)
        log.info("client %s (%s) disconnected", self.node, self.peer or "?")

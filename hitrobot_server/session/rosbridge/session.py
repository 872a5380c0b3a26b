"""One connected client: parses its ops, keeps its state, and talks to the bus.

The session owns no socket. A transport feeds it frames (``receive``) or decoded objects
(``handle``) and drains ``outbox``; that is all a transport does. Both return ``None`` once the
op is done, or a task when a big op went to the worker pool (session/offload.py): the transport
awaits it before feeding the next frame, so one client's ops still run in the order sent.
"""

from __future__ import annotations

import asyncio
import functools
import itertools
import logging
from collections.abc import Callable, Coroutine
from dataclasses import dataclass, field
from typing import Any

from ...bus.core import Bus
from ...bus.errors import BusError
from ...bus.topics import Origin
from ...protocol import auth, bulk, cbor, ops, png
from ...protocol.access import Grant
from ...protocol.errors import ProtocolError, message_id, should_send, status_op
from ...protocol.fragment import MIN_FRAGMENT_SIZE, FragmentBudget
from ...types import jsoncodec
from ...types.convert import ConversionError
from ...wire.frames import Frames
from ..access import Access, origin_of
from ..client import Pending
from ..core import STREAM_ERRORS_PER_SECOND, ClientCore
from ..offload import WorkerPool
from ..options import SessionOptions
from . import signin
from .actions import ActionOps
from .fragments import IncomingFragments
from .frames import FrameBuilder, json_frames
from .publish import PublishOps, TopicNames
from .services import ServiceOps
from .subscribe import SubscribeOps

log = logging.getLogger(__name__)

REFUSED_WHEN_FULL = (ops.CallService, ops.SendActionGoal)
"""Ops refused while the client's replies are over ``--reply-buffer-limit``: each would queue
another reply for a client that does not read the ones it has."""


@dataclass
class Shared:
    """What every client of one server shares, so limits hold for all of them together."""

    fragments: FragmentBudget  # bytes of incoming fragments held, all clients together
    auth_replays: auth.ReplayCache  # auth MACs already accepted (each grants access once)
    access: Access = field(default_factory=Access)  # tokens and roles (the server's)
    pool: WorkerPool = field(default_factory=WorkerPool)  # big ops off the event loop
    client_ids: itertools.count = field(default_factory=lambda: itertools.count(1))
    frames: FrameBuilder = field(init=False)  # builds every client's frames (one fragment
    # id counter for all), big ones in the pool

    def __post_init__(self) -> None:
        self.frames = FrameBuilder(self.pool.run)

    @classmethod
    def for_options(cls, options: SessionOptions, pool: WorkerPool | None = None) -> Shared:
        return cls(FragmentBudget(options.fragment_memory_limit), auth.ReplayCache(),
                   Access(options.authenticate), pool or WorkerPool())


class Session:
    """Per-client protocol state machine (transport-independent)."""

    def __init__(
        self,
        bus: Bus,
        settings: SessionOptions,
        *,
        peer: str = "",
        transport: str = "ws",
        shared: Shared | None = None,
        grant: Grant | None = None,
    ):
        self.bus = bus
        self._own_pool = shared is None  # made here (no server): its workers go with it
        self.shared = shared or Shared.for_options(settings)
        self.pool = self.shared.pool
        self.frames = self.shared.frames
        self.settings = settings
        self.transport = transport
        self.client_id = next(self.shared.client_ids)
        self.core = ClientCore(bus, settings, str(self.client_id), peer, _error_frames)
        self.peer, self.node, self.outbox = peer, self.core.node, self.core.outbox
        self.on_close: list[Callable[[Session], None]] = self.core.on_close
        self.limits = self.core.limits
        self.status_level = settings.status_level
        self.authenticated = not settings.authenticate
        self.auth_level: str | None = None
        self.fragments = IncomingFragments(self, settings, self.shared.fragments)
        topic_names = TopicNames(settings.topics_filter)
        self.publishing = PublishOps(self, topic_names)
        self.subscriptions = SubscribeOps(self, topic_names)
        self.service_ops = ServiceOps(self)
        self.action_ops = ActionOps(self)
        self._handlers = self._op_table()
        if grant is not None and settings.authenticate:  # its upgrade request's token
            self.authorize(grant)
        log.info("client %s connected from %s over %s", self.node, peer or "?", transport)

    def _op_table(self) -> dict[type, Callable[[Any], Pending]]:
        """Each op type's handler; publish is not here: it also takes the op's text (see
        handle)."""
        return {
            ops.Fragment: self._op_fragment,
            ops.Png: self._op_png,
            ops.SetLevel: self._op_set_level,
            ops.Auth: self._op_auth,
            ops.Advertise: self.publishing.advertise,
            ops.Unadvertise: self.publishing.unadvertise,
            ops.Subscribe: self.subscriptions.subscribe,
            ops.Unsubscribe: self.subscriptions.unsubscribe,
            ops.CallService: self.service_ops.call_service,
            ops.AdvertiseService: self.service_ops.advertise_service,
            ops.UnadvertiseService: self.service_ops.unadvertise_service,
            ops.ServiceResponse: self.service_ops.service_response,
            ops.AdvertiseAction: self.action_ops.advertise_action,
            ops.UnadvertiseAction: self.action_ops.unadvertise_action,
            ops.SendActionGoal: self.action_ops.send_action_goal,
            ops.CancelActionGoal: self.action_ops.cancel_action_goal,
            ops.ActionFeedback: self.action_ops.action_feedback,
            ops.ActionResult: self.action_ops.action_result,
        }

    @property
    def origin(self) -> Origin:
        return self.core.origin

    @property
    def closed(self) -> bool:
        return self.core.closed

    @property
    def close_reason(self) -> str:
        return self.core.close_reason

    # ------------------------------------------------------------------ input
    def receive(self, data: str | bytes, binary: bool = False) -> Pending:
        """One WebSocket frame (text JSON, or binary CBOR) or a re-assembled text."""
        if len(data) >= bulk.OFFLOAD_BYTES:
            if not self.authenticated:  # nothing big is parsed for a client not logged in
                self._reject_unauthenticated("message", None)
                return None
            return self._offload(bulk.decode_cbor if binary else bulk.decode_json, data)
        try:
            obj = cbor.decode(data) if binary else jsoncodec.loads(data)
        except Exception as exc:  # JSONDecodeError, CBORDecodeError, jsoncodec.InvalidValue
            kind = "CBOR" if binary else "JSON"
            if not self.authenticated:
                self._reject_unauthenticated(f"invalid {kind}", None)
                return None
            self.status("error", f"invalid {kind}: {exc}", getattr(exc, "id", None))
            return None
        return self.handle(obj, None if binary else data)  # a publish may send its text on

    def stream_error(self, error: ProtocolError) -> None:
        """Report unparseable input of a byte stream (TCP). Before auth it closes, like any
        other first op; after, errors of an op (with an id) are all reported, but garbage at
        most :data:`STREAM_ERRORS_PER_SECOND` times a second, then once that the rest of that
        second is not, so a stream of junk cannot flood the client or the log."""
        if not self.authenticated:
            self._reject_unauthenticated("invalid JSON", error.id)
            return
        if error.id is None:
            seen = self.core.garbage()
            if seen > STREAM_ERRORS_PER_SECOND:
                if seen == STREAM_ERRORS_PER_SECOND + 1:
                    self.status("error", "invalid JSON: more invalid input; not reported for "
                                "the rest of this second")
                return
        self.status(error.level, error.msg, error.id)

    def _offload(self, decode: Callable[[Any], object], data: object, op_id: Any = None) -> Pending:
        """Decode a big frame (or png payload) in the worker pool, then handle it here."""

        return self.spawn(_handle_big(self, decode, data, op_id))

    def handle(self, obj: object, frame: str | bytes | None = None) -> Pending:
        """Run one decoded op; every failure becomes a status message, never an exception.

        ``frame`` is the JSON text ``obj`` was decoded from, when known: a publish may send it
        on as the outgoing op instead of encoding the message again.
        """
        if not self.authenticated and not (isinstance(obj, dict) and obj.get("op") == "auth"):
            name = obj.get("op") if isinstance(obj, dict) else None
            self._reject_unauthenticated(
                name if isinstance(name, str) else "message", message_id(obj)
            )
            return None
        try:
            op = ops.validate_op(ops.parse_message(obj))
            if self._refused(op):
                return None
            if isinstance(op, ops.Publish):
                return self.publishing.publish(op, frame)
            if isinstance(op, REFUSED_WHEN_FULL) and self._replies_full(op):
                return None
            return self._handlers[type(op)](op)
        except ProtocolError as exc:
            self.service_ops.invalid_response(obj, exc.msg)
            self.status(exc.level, exc.msg, exc.id if exc.id is not None else message_id(obj))
        except (BusError, ConversionError) as exc:
            name = obj.get("op") if isinstance(obj, dict) else "?"
            self.status("error", f"{name}: {exc}", message_id(obj))
        except Exception as exc:
            log.exception("client %s: op failed", self.node)
            self.status("error", f"internal error: {exc}", message_id(obj))
        return None

    def _replies_full(self, op: ops.CallService | ops.SendActionGoal) -> bool:
        """Refuse a request while this client's unread replies are over the budget (the
        transport has stopped reading its input, but one read may hold many ops)."""
        limit = self.settings.reply_buffer_limit
        queued = self.outbox.control_bytes
        calls = self.service_ops.in_flight  # this client's call_service ops not answered yet
        if not self.core.replies_full(calls):
            return False
        text = (f"{op.OP}: too many requests in flight: {calls} call(s) "
                f"pending and {queued} bytes of replies not read yet "
                f"(--reply-buffer-limit {limit}); refused")
        if isinstance(op, ops.CallService):
            self.send(ops.service_response(op.service, op.id, text, False))
        self.status("error", text, op.id)
        return True

    def _op_fragment(self, op: ops.Fragment) -> Pending:
        text = self.fragments.add(op)
        return None if text is None else self.receive(text)

    def _op_png(self, op: ops.Png) -> Pending:
        if len(op.data) >= bulk.OFFLOAD_BYTES:
            decode = functools.partial(bulk.decode_png, max_bytes=self.settings.max_frame_size)
            return self._offload(decode, op.data, op.id)
        try:
            text = png.decode(op.data, self.settings.max_frame_size)
        except Exception as exc:
            raise ProtocolError(
                f"png: field 'data' is not a valid PNG payload: {exc}", op.id
            ) from None
        return self.receive(text)

    def _op_set_level(self, op: ops.SetLevel) -> None:
        self.status_level = op.level  # one of LEVELS: the op's spec checked it
        self.status("info", f"status level set to {self.status_level}", op.id)

    def _refused(self, op: object) -> bool:
        """The one role check of every rosbridge op, before it acts (:func:`checked_op`);
        a refusal is an error status naming the role and the permission (a call also gets its
        failed ``service_response``)."""
        what = checked_op(op)
        if what is None:
            return False
        reason = self.shared.access.check(self.origin, *what)
        if reason is None:
            return False
        if isinstance(op, ops.CallService):
            self.send(ops.service_response(op.service, op.id, reason, False))
        self.status("error", f"{getattr(op, 'OP', 'op')}: {reason}", getattr(op, "id", None))
        return True

    def authorize(self, grant: Grant, auth_level: str | None = None) -> None:
        """The client is ``grant`` (a token at the upgrade, or an ``auth`` op)."""
        self.authenticated = True
        self.auth_level = auth_level
        self.core.origin = origin_of(self.node, self.peer, grant, auth_level)

    def _op_auth(self, op: ops.Auth) -> None:
        signin.auth(self, op)

    def _reject_unauthenticated(self, what: str, op_id: Any) -> None:
        self.status("error", f"{what}: not authenticated; send 'auth' first", op_id)
        self.close_connection()

    # ------------------------------------------------------------------ output
    def send(
        self, obj: dict, *, fragment_size: int | None = None, compression: str = "none"
    ) -> None:
        """Queue a reply op; replies are never dropped by the send buffer."""
        size = fragment_size or self.settings.max_message_size
        self.core.reply(self.frames.reply(obj, size, compression))

    def fragment_size(self, op: ops.Subscribe | ops.CallService | ops.SendActionGoal) -> int | None:
        """The op's ``fragment_size``, raised to the floor (with a warning) when below it."""
        size = op.fragment_size
        if size is not None and size < MIN_FRAGMENT_SIZE:
            self.status(
                "warning",
                f"{op.OP}: field 'fragment_size' {size} is below the minimum of "
                f"{MIN_FRAGMENT_SIZE}; fragments of {MIN_FRAGMENT_SIZE} characters are sent",
                op.id,
            )
            return MIN_FRAGMENT_SIZE
        return size

    def status(self, level: str, msg: str, op_id: Any = None) -> None:
        if level == "error":
            log.info("client %s: %s", self.node, msg)
        if not should_send(self.status_level, level):
            return
        if level == "error" and self.core.skip_error():
            return
        try:
            frames = json_frames(status_op(level, msg, op_id))
        except TypeError:  # a text or id that cannot be encoded must not lose the report
            text = msg.encode("utf-8", "backslashreplace").decode("utf-8")
            frames = json_frames(status_op(level, text))
        self.core.notice(frames)

    def spawn(self, coro: Coroutine[Any, Any, Any]) -> asyncio.Task:
        """Run a coroutine tied to this client; it is cancelled when the client goes."""
        return self.core.spawn(coro)

    # ------------------------------------------------------------------ lifecycle
    def close_connection(self) -> None:
        """Ask the transport to close after flushing what is queued."""
        self.outbox.close()

    def close(self) -> None:
        """The connection is gone: release everything this client held on the bus."""
        if not self.core.close():
            return
        self.fragments.close()
        self.subscriptions.close()
        self.service_ops.close()
        self.action_ops.close()
        self.publishing.close()
        self.core.release(self)
        self._handlers.clear()  # bound methods of the op objects: session ↔ ops cycles
        if self._own_pool:
            self.pool.shutdown()
        log.info("client %s (%s) disconnected", self.node, self.peer or "?")


async def _handle_big(
    session: Session, decode: Callable[[Any], object], data: object, op_id: Any
) -> None:
    """A big frame (or png payload) decoded in the worker pool, then handled by the session."""
    try:
        obj = await session.pool.run(decode, data)
    except bulk.PngError as exc:
        session.status("error", f"png: field 'data' is not a valid PNG payload: {exc}", op_id)
        return
    except bulk.DecodeError as exc:
        kind = "CBOR" if decode is bulk.decode_cbor else "JSON"
        session.status("error", f"invalid {kind}: {exc}", exc.id)
        return
    except Exception as exc:  # the pool broke (a worker was killed): say so, go on
        log.exception("client %s: decoding a big op failed", session.node)
        session.status("error", f"internal error: {exc}", op_id)
        return
    more = session.handle(obj)
    if more is not None:
        await more


def checked_op(op: object) -> tuple[str, str, object] | None:
    """What an op asks, for the role check: (kind, name, message); None for an op that acts
    only on what the client already holds (unsubscribe, a response to a call it served)."""
    match op:
        case ops.Publish():
            return "publish", op.topic, op.msg
        case ops.Advertise():
            return "publish", op.topic, None
        case ops.Subscribe():
            return "subscribe", op.topic, None
        case ops.CallService():
            return "call", op.service, op.args
        case ops.AdvertiseService():
            return "provide", op.service, None
        case ops.AdvertiseAction():
            return "provide", op.action, None
        case ops.SendActionGoal():
            return "goal", op.action, op.args
        case ops.CancelActionGoal():
            return "cancel", op.action, None
    return None


def _error_frames(text: str) -> Frames:
    """An error status, as the client core queues one (its own reports, a disconnect)."""
    return json_frames(status_op("error", text))

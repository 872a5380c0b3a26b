"""One Foxglove (or Lichtblick) client: the Foxglove WebSocket protocol on the bus.

The twin of the rosbridge session for clients that ask for the ``foxglove.websocket.v1`` (or
``foxglove.sdk.v1``) subprotocol: the same :class:`~..client.ClientSession` shape
(``receive``, ``outbox``, ``close``), same bus, the same client core (session/core.py: identity,
outbox, limits, tasks, release). Every topic of the whole graph (this process and those its
link joins) the ``--topics-glob`` allows is a channel (CDR, ``ros2msg`` schema) kept current as
topics come and go. Protocol parsing and building are in protocol/foxglove.py; the ops are in
this package's op groups (channels, subscribe, publish, services, params, graph); this module
holds the client's input, its sync with the graph and its life.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import uuid
from collections.abc import Callable, Coroutine
from typing import Any

from ...bus.core import Bus
from ...bus.errors import BusError
from ...bus.params import ParamError, without_gc
from ...protocol import foxglove as fg
from ...protocol.access import Grant
from ...protocol.foxglove_playback import CLIENT_PLAYBACK_CONTROL_REQUEST
from ..access import origin_of
from ..client import Pending
from ..core import ClientCore
from ..options import SessionOptions
from .channels import ChannelOps
from .frames import FoxgloveOutput, status_frames
from .graph import GraphOps
from .guard import PLAYBACK, refusal
from .params import ParamOps
from .playback import PlaybackOps
from .publish import PublishOps
from .services import ServiceOps
from .shared import FoxgloveShared
from .subscribe import SubscribeOps

log = logging.getLogger(__name__)

TIME_PERIOD = 0.1
"""Seconds between two ``time`` messages (the bus clock) to each client."""
PLAYBACK_REQUEST = bytes([CLIENT_PLAYBACK_CONTROL_REQUEST])
MAX_TEXT_BYTES = 16 * 1024 * 1024
"""Largest JSON op accepted (ops are small; binary frames carry the data)."""
PAUSE_GC_BYTES = 16 * 1024
"""JSON ops from this size up are parsed with the garbage collector paused."""
BATCH = 256
"""Entries of a listing op handled in one step of the event loop: an op of 10,000 channels
is handled in steps of this many, other clients served in between."""
SYNC_BATCH = 16
"""Topics (or services) synced in one step of the event loop: a type a Foxglove client is
told of first costs its schema (a few ms)."""


class FoxgloveSession:
    """Per-client Foxglove protocol state; owns no socket (the transport feeds and drains it)."""

    def __init__(
        self,
        bus: Bus,
        settings: SessionOptions,
        shared: FoxgloveShared,
        *,
        peer: str = "",
        subprotocol: str = fg.SUBPROTOCOL_V1,
        server_name: str = "hitrobot-server",
        grant: Grant | None = None,
    ):
        self.bus = bus
        self.settings = settings
        self.shared = shared
        self.codec = shared.codec
        self.subprotocol = subprotocol
        # under the rosbridge clients' prefix, so diagnostics' /Bridge/Clients counts it too
        self.core = ClientCore(bus, settings, f"foxglove_{next(shared.client_ids)}", peer,
                               lambda text: status_frames(fg.ERROR, text))
        self.peer, self.node, self.outbox = peer, self.core.node, self.core.outbox
        if grant is not None and settings.authenticate:  # the token of its upgrade request
            self.core.origin = origin_of(self.node, peer, grant)
        self.origin = self.core.origin
        self.on_close: list[Callable[[FoxgloveSession], None]] = self.core.on_close
        self.pool = shared.pool
        self.out = FoxgloveOutput(self.core)
        self._changes: set[tuple[str, str]] = set()  # (kind, name) changed since the last sync
        self.channel_ops = ChannelOps(self)
        self.channels = self.channel_ops.channels  # channel id advertised → topic
        self.subscriptions = SubscribeOps(self, self.channels)
        self.subs = self.subscriptions.subs  # subscription id → topic
        self.publishing = PublishOps(self)
        self.service_ops = ServiceOps(self, self.channel_ops.services)
        self.param_ops = ParamOps(self)
        self.graph_ops = GraphOps(self)
        self.playback = PlaybackOps(self)  # replay's playbackControl (helper replay)
        self._handlers = self._op_table()
        self._wake = asyncio.Event()  # set when _changes has something to sync
        self._time_handle: asyncio.TimerHandle | None = None
        log.info("foxglove client %s connected from %s (%s)", self.node, peer or "?", subprotocol)
        if settings.authenticate and grant is None:
            # The protocol has no auth op: the token comes with the upgrade request.
            self.out.status(fg.ERROR, "this server requires a token (--authenticate): give it "
                            "as ?token= in the URL or an 'Authorization: Bearer' header; "
                            "closing")
            self.outbox.close()
            return
        self.out.send(self.playback.describe(
            fg.server_info(server_name, uuid.uuid4().hex, {"ROS_DISTRO": "jazzy"})))
        # the channels and services there are, told at once (one advertise of each)
        self.channel_ops.sync_channels(self.subscriptions, self.channel_ops.topic_names())
        self.channel_ops.sync_services(self.channel_ops.service_names())
        shared.graph.watch(self._changed)  # here and across the link (other workers)
        self.spawn(self._sync_loop())
        bus.params.watchers.append(self._param_changed)
        self._time_handle = asyncio.get_running_loop().call_soon(self._tick)

    @property
    def close_reason(self) -> str:
        """Why the server disconnected the client (the transport closes with it, 1008)."""
        return self.core.close_reason

    @property
    def closed(self) -> bool:
        return self.core.closed

    def _op_table(self) -> dict[type, Callable[[Any], None]]:
        """Each JSON op's handler, by the class its parser (protocol/foxglove.py) made."""
        return {
            fg.Subscribe: self.subscriptions.subscribe,
            fg.Unsubscribe: self.subscriptions.unsubscribe,
            fg.Advertise: self.publishing.advertise,
            fg.Unadvertise: self.publishing.unadvertise,
            fg.GetParameters: self._get_parameters,
            fg.SetParameters: self.param_ops.set,
            fg.SubscribeParameterUpdates: self.param_ops.subscribe,
            fg.UnsubscribeParameterUpdates: self.param_ops.unsubscribe,
            fg.SubscribeConnectionGraph: self.graph_ops.subscribe,
            fg.UnsubscribeConnectionGraph: self.graph_ops.unsubscribe,
            fg.FetchAsset: _fetch_asset,
        }

    # ------------------------------------------------------------------ input
    def receive(self, data: str | bytes, binary: bool = False) -> Pending:
        """One WebSocket frame; every failure becomes an error status, never an exception.
        A task when a big message is being decoded in the worker pool (the transport awaits
        it before the next frame, so one client's frames keep their order)."""
        if self.core.closed or self.outbox.closed:
            return None
        try:
            if binary:
                raw = data if isinstance(data, bytes) else data.encode()
                if raw[:1] == PLAYBACK_REQUEST:  # replay's playbackControl
                    return None if self._refused(PLAYBACK) else self.playback.request(raw)
                frame = fg.parse_binary(raw)
                return None if self._refused(frame) else self._binary(frame)
            if len(data) > MAX_TEXT_BYTES:
                raise fg.FoxgloveError(
                    f"text frame of {len(data)} bytes: JSON ops are at most "
                    f"{MAX_TEXT_BYTES} bytes; message data goes in binary frames"
                )
            op = _parse_op(data)
            if self._refused(op):
                return None
            field = op.LISTS
            if field is not None and len(getattr(op, field)) > BATCH:
                return self.spawn(self._batched(op, field))
            self._handlers[type(op)](op)
        except fg.FoxgloveError as exc:
            self.out.status(fg.ERROR, str(exc))
        except (BusError, ParamError) as exc:  # a refusal of the bus, named by it
            self.out.status(fg.ERROR, str(exc))
        except Exception as exc:
            log.exception("foxglove client %s: frame failed", self.node)
            self.out.status(fg.ERROR, f"internal error: {exc}")
        return None

    def _refused(self, item: object) -> bool:
        """The one role check of every op (guard.py); a refused call also fails."""
        reason = refusal(self, item)
        if reason is None:
            return False
        if isinstance(item, fg.ServiceCallRequest):
            self.out.send(fg.service_call_failure(item.service_id, item.call_id, reason))
        self.out.status(fg.ERROR, reason)
        return True

    def _binary(self, frame: fg.ClientMessage | fg.ServiceCallRequest) -> Pending:
        if isinstance(frame, fg.ClientMessage):
            return self.publishing.message(frame)
        self.service_ops.call(frame)
        return None

    async def _batched(self, op: fg.ClientOp, field: str) -> None:
        """A long listing op in steps of :data:`BATCH` entries (the transport reads this
        client's next frame once all are done); its refusals still make one status each."""
        entries, handler = getattr(op, field), self._handlers[type(op)]
        self.out.gather()
        try:
            for start in range(0, len(entries), BATCH):
                if self.closed:
                    return
                handler(dataclasses.replace(op, **{field: entries[start:start + BATCH]}))
                await asyncio.sleep(0)
        finally:
            if not self.closed:
                self.out.flush()

    def _get_parameters(self, op: fg.GetParameters) -> None:
        """``getParameters``, refused while this client's unread replies are over its budget
        (each reply may be the whole parameter tree)."""
        if self.out.full:
            raise fg.FoxgloveError(
                f"getParameters: too many requests in flight: {self.outbox.control_bytes} "
                f"bytes of replies not read yet (--reply-buffer-limit {self.out.reply_limit}); "
                "refused")
        self.param_ops.get(op)

    def spawn(self, coro: Coroutine[Any, Any, Any]) -> asyncio.Task:
        """Run a coroutine tied to this client; it is cancelled when the client goes."""
        return self.core.spawn(coro)

    # ------------------------------------------------------------------ the graph changed
    def _changed(self, kind: str, name: str) -> None:
        """The graph changed (here or in a process the link joins): sync what changed of
        channels, services and the graph once, after this step (the sync loop wakes)."""
        if self.core.closed:
            return
        self._changes.add((kind, name))
        self._wake.set()

    async def _sync_loop(self) -> None:
        """The client's one sync task, for its life: each wake-up syncs what changed since
        (a burst of changes is one sync). It ends when the client goes (the core cancels it)."""
        while True:
            await self._wake.wait()
            self._wake.clear()
            try:
                await self._sync()
            except Exception:  # the next change syncs again
                log.exception("foxglove client %s: sync failed", self.node)

    async def _sync(self) -> None:
        """Channels, services and the graph brought up to date: for the names changed since
        the last sync (everything after an action changed), in steps of
        :data:`SYNC_BATCH` names (a name seen first costs its schema), other clients served in
        between."""
        while self._changes and not self.closed:
            changes, self._changes = self._changes, set()
            everything = any(kind == "action" for kind, _name in changes)
            ops = self.channel_ops
            topics = ops.topic_names() if everything else \
                {name for kind, name in changes if kind == "topic"}
            services = ops.service_names() if everything else \
                {name for kind, name in changes if kind == "service"}
            self.shared.prune()
            for part in _batches(topics):
                ops.sync_channels(self.subscriptions, part)
                await asyncio.sleep(0)
            for part in _batches(services):
                ops.sync_services(part)
                await asyncio.sleep(0)
            if not everything:
                self.graph_ops.changed(topics, services)
            elif self.graph_ops.graph is not None:
                self.graph_ops.send()

    def _param_changed(self, name: str) -> None:
        if not self.closed:
            self.param_ops.changed(name)

    def _tick(self) -> None:
        """The bus clock, every :data:`TIME_PERIOD` (the ``time`` capability)."""
        if self.closed or self.outbox.closed:
            return
        self.out.data([(fg.time(fg.nanoseconds(self.bus.clock())), True)], "")
        self._time_handle = asyncio.get_running_loop().call_later(TIME_PERIOD, self._tick)

    # ------------------------------------------------------------------ lifecycle
    def close(self) -> None:
        """The connection is gone: release everything this client held on the bus."""
        if not self.core.close():
            return
        if self._time_handle is not None:
            self._time_handle.cancel()
        self.shared.graph.unwatch(self._changed)
        if self._param_changed in self.bus.params.watchers:
            self.bus.params.watchers.remove(self._param_changed)
        self.subscriptions.close()
        self.playback.close()
        self.core.release(self)
        self._handlers.clear()  # bound methods of the op groups: session ↔ ops cycles
        log.info("foxglove client %s (%s) disconnected", self.node, self.peer or "?")


def _parse_op(data: str | bytes) -> fg.ClientOp:
    """``fg.parse_op``, with the cyclic garbage collector paused for a long op: one of 10,000
    entries makes 40,000 objects, whose creation would trigger a collection walking the whole
    server (100 ms) that their reference counts make useless (as the parameter store parses).
    An op under :data:`PAUSE_GC_BYTES` makes too few to matter."""
    if len(data) < PAUSE_GC_BYTES:
        return fg.parse_op(data)
    return without_gc(fg.parse_op, data)


def _batches(names: set[str]) -> list[list[str]]:
    ordered = sorted(names)
    return [ordered[i:i + SYNC_BATCH] for i in range(0, len(ordered), SYNC_BATCH)]


def _fetch_asset(op: fg.FetchAsset) -> None:
    raise fg.FoxgloveError("fetchAsset: this server has no 'assets' capability")

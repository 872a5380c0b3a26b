"""One Foxglove (or Lichtblick) client: the Foxglove WebSocket protocol on the bus.

The twin of :class:`~hitrobot_server.session.session.Session` for clients that ask for the
``foxglove.websocket.v1`` (or ``foxglove.sdk.v1``) subprotocol: same transport interface
(``receive``, ``outbox``, ``close``), same bus, same per-client send bound. Every bus topic the
``--topics-glob`` allows is a channel (CDR, ``ros2msg`` schema) kept current as topics come and
go; a message's CDR is encoded once (its ``Encoded``, shared with the Zenoh link) and
every subscriber gets it behind its own 13-byte header. Protocol parsing and building are in
protocol/foxglove.py; this module holds the per-client state.
"""

from __future__ import annotations

import asyncio
import functools
import itertools
import logging
import uuid
from collections.abc import Callable, Coroutine
from dataclasses import dataclass, field
from typing import Any

from ..bus.cdr import Ros2Codec, codec_for
from ..bus.core import Bus
from ..bus.errors import BusError
from ..bus.names import canonical, valid_name
from ..bus.topics import Message, Origin, Topic
from ..protocol import foxglove as fg
from ..types.registry import MsgType, SrvType, UnknownType
from ..wire.encoded import encoded_of
from ..wire.frames import Frames
from .options import SessionOptions
from .outbox import Outbox
from .session import release_client

log = logging.getLogger(__name__)
_client_ids = itertools.count(1)

TIME_PERIOD = 0.1
"""Seconds between two ``time`` messages (the bus clock) to each client."""
MAX_TEXT_BYTES = 16 * 1024 * 1024
"""Largest JSON op accepted (ops are small; binary frames carry the data)."""
MAX_CALLS = 64
"""Most service calls of one client waiting for their provider at once."""
MAX_REMEMBERED = 4096
"""Channels/services remembered server-wide before those no longer on the bus are forgotten."""


@dataclass
class FoxgloveShared:
    """What all Foxglove clients of one server share: one codec, and channel and service ids
    that mean the same topic or service to every client (and so share encoded frames)."""

    codec: Ros2Codec
    _channels: dict[tuple[str, str], dict] = field(default_factory=dict)
    _services: dict[tuple[str, str], dict] = field(default_factory=dict)
    _ids: itertools.count = field(default_factory=lambda: itertools.count(1))

    @classmethod
    def for_bus(cls, bus: Bus) -> FoxgloveShared:
        return cls(codec_for(bus.types))

    def prune(self, bus: Bus) -> None:
        """Forget channels and services gone from the bus once there are many (clients can
        make topics and services of any name): a returning topic then gets a new id."""
        if len(self._channels) > MAX_REMEMBERED:
            live = {(t.name, t.type_name) for t in list(bus.topics.values())}
            self._channels = {k: v for k, v in self._channels.items() if k in live}
        if len(self._services) > MAX_REMEMBERED:
            live = {(n, s.stype.name) for n, s in list(bus.services.items())}
            self._services = {k: v for k, v in self._services.items() if k in live}

    def channel(self, topic: Topic) -> dict | None:
        """The channel of a topic (its id and schema), or None when it has no ROS 2 schema."""
        key = (topic.name, topic.type_name)
        found = self._channels.get(key)
        if found is None:
            try:
                schema = self.codec.definition(topic.type_name)
            except Exception as exc:
                log.debug("no ros2msg schema for %s (%s): %s", topic.name, topic.type_name, exc)
                return None
            found = self._channels[key] = fg.channel(
                next(self._ids), topic.name, topic.type_name, schema
            )
        return found

    def service(self, name: str, stype: SrvType) -> dict | None:
        key = (name, stype.name)
        found = self._services.get(key)
        if found is None:
            try:
                req = (stype.request.name, self.codec.definition(stype.request.name))
                resp = (stype.response.name, self.codec.definition(stype.response.name))
            except Exception as exc:
                log.debug("no ros2msg schema for service %s: %s", name, exc)
                return None
            found = self._services[key] = fg.service(next(self._ids), name, stype.name, req,
                                                     resp)
        return found


@dataclass(slots=True)
class _ClientChannel:
    topic: str
    mtype: MsgType


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
    ):
        self.bus = bus
        self.settings = settings
        self.shared = shared
        self.codec = shared.codec
        self.peer = peer
        self.subprotocol = subprotocol
        # under the rosbridge clients' prefix, so diagnostics' /Bridge/Clients counts it too
        self.node = f"/hitrobot_client_{settings.client_tag}foxglove_{next(_client_ids)}"
        self.origin = Origin(self.node)
        self.outbox = Outbox(settings.send_buffer_limit)
        self.closed = False
        self.close_reason = ""  # the transport closes with it (1008) when set; never set here
        self.on_close: list[Callable[[FoxgloveSession], None]] = []
        self.channels: dict[int, str] = {}  # channel id advertised to this client → topic
        self.subs: dict[int, str] = {}  # subscription id → topic
        self.client_channels: dict[int, _ClientChannel] = {}
        self.services: dict[int, tuple[str, SrvType]] = {}  # service id → (name, type)
        self.param_subs: set[str] = set()
        self.graph: tuple[dict, dict, dict] | None = None  # last graph sent, if subscribed
        self._bad_encodings: set[str] = set()
        self._tasks: set[asyncio.Task] = set()
        self._sync_handle: asyncio.Handle | None = None
        self._time_handle: asyncio.TimerHandle | None = None
        bus.register_node(self.node)
        log.info("foxglove client %s connected from %s (%s)", self.node, peer or "?", subprotocol)
        if settings.authenticate:
            # The protocol has no auth op: with --authenticate nothing is served to it.
            self._status(fg.ERROR, "this server requires authentication (--authenticate), which "
                         "the Foxglove protocol cannot carry: use a rosbridge connection with "
                         "'auth'; closing")
            self.outbox.close()
            return
        self._send(fg.server_info(server_name, uuid.uuid4().hex, {"ROS_DISTRO": "jazzy"}))
        self._sync()
        bus.watchers.append(self._changed)
        bus.params.watchers.append(self._param_changed)
        self._time_handle = asyncio.get_running_loop().call_soon(self._tick)

    # ------------------------------------------------------------------ output (one place)
    def _send(self, obj: dict) -> None:
        """A reply or announcement: never dropped by the send bound."""
        self.outbox.put([(fg.dumps(obj), False)])

    def _send_binary(self, data: bytes) -> None:
        self.outbox.put([(data, True)])

    def _send_data(self, frames: Frames, topic: str) -> None:
        """Topic data, in the topic's own fair-share stream: when the client's buffer is full,
        the topic over its share loses its oldest messages (the outbox's scheduler)."""
        self.outbox.put(frames, droppable=True, key=topic)

    def _status(self, level: int, message: str, status_id: str | None = None) -> None:
        """A status goes through the bounded buffer like topic data: a client that floods
        junk without reading loses its own oldest reports, and costs at most its bound."""
        if level == fg.ERROR:
            log.info("foxglove client %s: %s", self.node, message)
        self.outbox.put([(fg.dumps(fg.status(level, message, status_id)), False)],
                        droppable=True)

    # ------------------------------------------------------------------ input
    def receive(self, data: str | bytes, binary: bool = False) -> None:
        """One WebSocket frame; every failure becomes an error status, never an exception."""
        if self.closed or self.outbox.closed:
            return None
        try:
            if binary:
                self._binary(fg.parse_binary(data if isinstance(data, bytes) else data.encode()))
            else:
                if len(data) > MAX_TEXT_BYTES:
                    raise fg.FoxgloveError(
                        f"text frame of {len(data)} bytes: JSON ops are at most "
                        f"{MAX_TEXT_BYTES}; message data goes in binary frames"
                    )
                op = fg.parse_text(data)
                self._handlers[op["op"]](self, op)
        except fg.FoxgloveError as exc:
            self._status(fg.ERROR, str(exc))
        except Exception as exc:
            log.exception("foxglove client %s: frame failed", self.node)
            self._status(fg.ERROR, f"internal error: {exc}")
        return None

    def _binary(self, frame: fg.ClientMessage | fg.ServiceCallRequest) -> None:
        if isinstance(frame, fg.ClientMessage):
            self._client_message(frame)
        else:
            self._service_call(frame)

    # ------------------------------------------------------------------ channels
    def _changed(self, kind: str, name: str) -> None:
        """The bus changed: sync channels, services and the graph once, after this step."""
        if self._sync_handle is None and not self.closed:
            self._sync_handle = asyncio.get_running_loop().call_soon(self._sync)

    def _sync(self) -> None:
        self._sync_handle = None
        if self.closed:
            return
        self.shared.prune(self.bus)
        allowed = self.settings.topics_filter.allows
        current: dict[int, dict] = {}
        for topic in list(self.bus.topics.values()):
            if allowed(topic.name):
                chan = self.shared.channel(topic)
                if chan is not None:
                    current[chan["id"]] = chan
        gone = [cid for cid in self.channels if cid not in current]
        new = [chan for cid, chan in current.items() if cid not in self.channels]
        if gone:
            topics = {chan["topic"] for chan in current.values()}
            for sub_id, topic in list(self.subs.items()):
                if topic not in topics:
                    self._unsubscribe(sub_id)
            for cid in gone:
                del self.channels[cid]
            self._send(fg.unadvertise(gone))
        if new:
            for chan in new:
                self.channels[chan["id"]] = chan["topic"]
            self._send(fg.advertise(new))
        self._sync_services()
        if self.graph is not None:
            self._send_graph()

    def _sync_services(self) -> None:
        allowed = self.settings.services_filter.allows
        current: dict[int, tuple[str, SrvType, dict]] = {}
        for name, svc in list(self.bus.services.items()):
            if allowed(name):
                desc = self.shared.service(name, svc.stype)
                if desc is not None:
                    current[desc["id"]] = (name, svc.stype, desc)
        gone = [sid for sid in self.services if sid not in current]
        new = [(sid, entry) for sid, entry in current.items() if sid not in self.services]
        if gone:
            for sid in gone:
                del self.services[sid]
            self._send(fg.unadvertise_services(gone))
        if new:
            for sid, (name, stype, _desc) in new:
                self.services[sid] = (name, stype)
            self._send(fg.advertise_services([desc for _sid, (_n, _t, desc) in new]))

    # ------------------------------------------------------------------ subscribe
    def _op_subscribe(self, op: dict) -> None:
        given: list[tuple[int, int]] = []
        for sub_id, channel_id in op["subscriptions"]:
            topic = self.channels.get(channel_id)
            if topic is None:
                self._status(fg.ERROR, f"subscribe: unknown channel id {channel_id}")
                continue
            if sub_id is None:
                if self.subprotocol == fg.SUBPROTOCOL_V1:
                    self._status(fg.ERROR, "subscribe: field 'subscriptions[].id' is required")
                    continue
                sub_id = next(i for i in itertools.count(1) if i not in self.subs)
            if sub_id in self.subs:
                self._status(fg.ERROR, f"subscribe: subscription id {sub_id} is already in use")
                continue
            self.subs[sub_id] = topic  # before subscribing: a latched topic delivers at once
            try:
                self.bus.subscribe(topic, None, (self, sub_id), self.node,
                                   functools.partial(self._deliver, sub_id))
            except BusError as exc:  # the topic went since it was advertised
                del self.subs[sub_id]
                self._status(fg.ERROR, f"subscribe: channel {channel_id}: {exc}")
                continue
            given.append((sub_id, channel_id))
        if self.subprotocol == fg.SUBPROTOCOL_SDK and given:
            self._send(fg.subscription_response(given))

    def _deliver(self, sub_id: int, message: Message) -> None:
        """Called by the bus for every message; must never block or raise."""
        try:
            cdr = message.cdr(self.codec)
        except Exception as exc:
            name = message.topic.name
            if name not in self._bad_encodings:
                self._bad_encodings.add(name)
                self._status(fg.WARNING, f"topic '{name}': a message could not be encoded as "
                             f"CDR ({exc}); such messages are skipped")
            return
        self._send_data([(encoded_of(message).foxglove(sub_id, cdr), True)], message.topic.name)

    def _op_unsubscribe(self, op: dict) -> None:
        for sub_id in op["subscriptionIds"]:
            if sub_id not in self.subs:
                self._status(fg.ERROR, f"unsubscribe: unknown subscription id {sub_id}")
                continue
            self._unsubscribe(sub_id)

    def _unsubscribe(self, sub_id: int) -> None:
        topic = self.subs.pop(sub_id)
        self.bus.unsubscribe(topic, (self, sub_id))

    # ------------------------------------------------------------------ client publish
    def _op_advertise(self, op: dict) -> None:
        for chan in op["channels"]:
            where = f"advertise: channel {chan.id}"
            if chan.id in self.client_channels:
                self._status(fg.ERROR, f"{where}: id already advertised")
                continue
            if chan.encoding != fg.ENCODING:
                self._status(fg.ERROR, f"{where}: field 'encoding' {chan.encoding!r:.40} is not "
                             f"supported (only '{fg.ENCODING}')")
                continue
            if not valid_name(chan.topic):
                self._status(fg.ERROR, f"{where}: field 'topic' {chan.topic!r:.80} is not a "
                             "valid topic name")
                continue
            name = canonical(chan.topic)
            if not self.settings.topics_filter.allows(name):
                self._status(fg.ERROR, f"{where}: topic '{name}' is not allowed by --topics-glob")
                continue
            try:
                mtype = self.bus.types.msg(chan.schema_name)
                self.bus.advertise(name, mtype.name, self, self.node)
            except (UnknownType, BusError) as exc:
                text = exc.args[0] if exc.args else exc
                self._status(fg.ERROR, f"{where}: field 'schemaName': {text}")
                continue
            self.client_channels[chan.id] = _ClientChannel(name, mtype)

    def _op_unadvertise(self, op: dict) -> None:
        for cid in op["channelIds"]:
            chan = self.client_channels.pop(cid, None)
            if chan is None:
                self._status(fg.ERROR, f"unadvertise: unknown client channel id {cid}")
                continue
            if all(c.topic != chan.topic for c in self.client_channels.values()):
                self.bus.unadvertise(chan.topic, self)

    def _client_message(self, frame: fg.ClientMessage) -> None:
        chan = self.client_channels.get(frame.channel_id)
        if chan is None:
            raise fg.FoxgloveError(f"message data: unknown client channel id {frame.channel_id}"
                                   " (advertise it first)")
        try:
            msg = self._decode(frame.payload, chan.mtype)
        except Exception as exc:
            raise fg.FoxgloveError(
                f"message data: channel {frame.channel_id} ({chan.topic}): the CDR does not "
                f"match {chan.mtype.name}: {exc}"
            ) from None
        try:
            self.bus.publish(chan.topic, msg, reply=self._reply, origin=self.origin)
        except BusError as exc:
            raise fg.FoxgloveError(f"message data: {exc}") from None

    def _decode(self, payload: bytes, mtype: MsgType) -> dict:
        """A message from CDR; a type without fields (``std_srvs/Trigger`` requests) needs no
        bytes, since writers differ on the padding byte ROS 2 puts in an empty struct."""
        if not mtype.fields:
            return {}
        return self.codec.decode(payload, mtype)

    def _reply(self, level: str, text: str) -> None:
        """A node's answer to a message this client published (refusals, successes)."""
        self._status({"info": fg.INFO, "warning": fg.WARNING}.get(level, fg.ERROR), text)

    # ------------------------------------------------------------------ services
    def _service_call(self, req: fg.ServiceCallRequest) -> None:
        entry = self.services.get(req.service_id)
        if entry is None:
            self._call_failed(req, f"unknown service id {req.service_id}")
            return
        name, stype = entry
        if len(self._tasks) >= MAX_CALLS:
            self._call_failed(req, f"{MAX_CALLS} calls of this client are already waiting for "
                              "their answers")
            return
        if req.encoding != fg.ENCODING:
            self._call_failed(req, f"encoding {req.encoding!r:.40} is not supported "
                              f"(only '{fg.ENCODING}')")
            return
        try:
            request = self._decode(req.payload, stype.request)
        except Exception as exc:
            self._call_failed(req, f"the request CDR does not match {stype.request.name}: {exc}")
            return
        self._spawn(self._call(req, name, stype, request))

    async def _call(self, req: fg.ServiceCallRequest, name: str, stype: SrvType,
                    request: dict) -> None:
        try:
            response = await self.bus.call_service(
                name, request, self.settings.call_service_timeout
            )
            payload = self.codec.encode(response, stype.response)
        except BusError as exc:
            self._send(fg.service_call_failure(req.service_id, req.call_id, str(exc)))
            return
        except Exception as exc:
            log.exception("foxglove client %s: service %s failed", self.node, name)
            self._send(fg.service_call_failure(req.service_id, req.call_id,
                                               f"service '{name}' failed: {exc}"))
            return
        self._send_binary(fg.service_call_response(req.service_id, req.call_id, fg.ENCODING,
                                                   payload))

    def _call_failed(self, req: fg.ServiceCallRequest, text: str) -> None:
        self._status(fg.ERROR, f"service call request {req.call_id}: {text}")
        self._send(fg.service_call_failure(req.service_id, req.call_id, text))

    # ------------------------------------------------------------------ parameters
    def _op_get_parameters(self, op: dict) -> None:
        """The values of the names asked (every leaf when none), those --params-glob allows
        and that are set; any other name is left out, as the spec's reply allows."""
        params, allowed = self.bus.params, self.settings.params_filter.allows
        names = op["parameterNames"] or params.names()
        values = [fg.param_to_wire(n, params.get(n)) for n in names
                  if valid_name(n) and allowed(n) and params.has(n)]
        self._send(fg.parameter_values(values, op["id"]))

    def _op_set_parameters(self, op: dict) -> None:
        pairs = op["parameters"]
        for name, _value in pairs:  # validate all first, then set
            if not valid_name(name) or canonical(name) == "/":
                raise fg.FoxgloveError(f"setParameters: field 'name' {name!r:.80} is not a valid "
                                       "parameter name")
            if not self.settings.params_filter.allows(name):
                raise fg.FoxgloveError(f"setParameters: parameter '{canonical(name)}' is not "
                                       "allowed by --params-glob")
        params = self.bus.params
        for name, value in pairs:
            if value is None:
                params.delete(name)
            else:
                params.set(name, value)
        if op["id"] is not None:
            values = [fg.param_to_wire(n, params.get(n)) if params.has(n) else {"name": n}
                      for n, _v in pairs]
            self._send(fg.parameter_values(values, op["id"]))

    def _op_subscribe_params(self, op: dict) -> None:
        self.param_subs.update(canonical(n) for n in op["parameterNames"])

    def _op_unsubscribe_params(self, op: dict) -> None:
        self.param_subs.difference_update(canonical(n) for n in op["parameterNames"])

    def _param_changed(self, name: str) -> None:
        if not self.param_subs or self.closed:
            return
        params, allowed = self.bus.params, self.settings.params_filter.allows
        hit = [n for n in self.param_subs if allowed(n) and (
               n == name or n.startswith(name.rstrip("/") + "/") or name.startswith(n + "/"))]
        if hit:
            self._send(fg.parameter_values(
                [fg.param_to_wire(n, params.get(n)) if params.has(n) else {"name": n}
                 for n in sorted(hit)]
            ))

    # ------------------------------------------------------------------ connection graph
    def _op_subscribe_graph(self, op: dict) -> None:
        self.graph = ({}, {}, {})
        self._send_graph()

    def _op_unsubscribe_graph(self, op: dict) -> None:
        self.graph = None

    def _send_graph(self) -> None:
        topics_ok = self.settings.topics_filter.allows
        published: dict[str, list[str]] = {}
        subscribed: dict[str, list[str]] = {}
        for topic in list(self.bus.topics.values()):
            if not topics_ok(topic.name):
                continue
            if topic.publishers:
                published[topic.name] = sorted(set(topic.publishers.values()))
            if topic.subscribers:
                subscribed[topic.name] = sorted({node for node, _cb in topic.subscribers.values()})
        services = {
            name: [svc.node]
            for name, svc in list(self.bus.services.items())
            if self.settings.services_filter.allows(name)
        }
        last = self.graph or ({}, {}, {})
        if (published, subscribed, services) == last:
            return
        removed_topics = sorted((set(last[0]) | set(last[1])) - set(published) - set(subscribed))
        removed_services = sorted(set(last[2]) - set(services))
        self.graph = (published, subscribed, services)
        self._send(fg.connection_graph_update(
            published, subscribed, services, removed_topics, removed_services
        ))

    # ------------------------------------------------------------------ the rest
    def _op_fetch_asset(self, op: dict) -> None:
        raise fg.FoxgloveError("fetchAsset: this server has no 'assets' capability")

    def _tick(self) -> None:
        """The bus clock, every :data:`TIME_PERIOD` (the ``time`` capability)."""
        if self.closed or self.outbox.closed:
            return
        self._send_data([(fg.time(fg.nanoseconds(self.bus.clock())), True)], "")
        self._time_handle = asyncio.get_running_loop().call_later(TIME_PERIOD, self._tick)

    def _spawn(self, coro: Coroutine[Any, Any, Any]) -> None:
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    _handlers: dict[str, Callable[[FoxgloveSession, dict], None]] = {
        "subscribe": _op_subscribe,
        "unsubscribe": _op_unsubscribe,
        "advertise": _op_advertise,
        "unadvertise": _op_unadvertise,
        "getParameters": _op_get_parameters,
        "setParameters": _op_set_parameters,
        "subscribeParameterUpdates": _op_subscribe_params,
        "unsubscribeParameterUpdates": _op_unsubscribe_params,
        "subscribeConnectionGraph": _op_subscribe_graph,
        "unsubscribeConnectionGraph": _op_unsubscribe_graph,
        "fetchAsset": _op_fetch_asset,
    }

    def close(self) -> None:
        """The connection is gone: release everything this client held on the bus."""
        if self.closed:
            return
        self.closed = True
        self.outbox.clear()  # freed now, not by the next full collection
        for handle in (self._sync_handle, self._time_handle):
            if handle is not None:
                handle.cancel()
        if self._changed in self.bus.watchers:
            self.bus.watchers.remove(self._changed)
        if self._param_changed in self.bus.params.watchers:
            self.bus.params.watchers.remove(self._param_changed)
        for sub_id in list(self.subs):
            self._unsubscribe(sub_id)
        release_client(self, self._tasks)
        log.info("foxglove client %s (%s) disconnected", self.node, self.peer or "?")

"""The bus joined to other processes over Zenoh, in rmw_zenoh's format (``--bus zenoh``).

What crosses, and how:

* topics: a local topic with publishers gets a Zenoh publisher and ``MP`` tokens; one with
  subscribers gets a Zenoh subscriber and ``MS`` tokens. A local publish is CDR-encoded and put
  only while some other process has a subscriber. Latched topics also answer queries on their
  key with the last message, and a new Zenoh subscriber queries once, so late joiners in other
  processes get it.
* services: a local service is a queryable (``SS``); a call that misses locally becomes a get
  on the provider's key, with the call's timeout; errors travel as reply errors with the text.
* actions: ROS 2's shape — ``<action>/_action/send_goal``, ``get_result`` and ``cancel_goal``
  queryables and the ``<action>/_action/feedback`` topic.
* discovery: liveliness tokens; a process that dies loses its tokens, so it leaves rosapi's
  lists and its proxies fail their calls.

Zenoh calls back on its own threads; every callback hops onto the event loop first.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import itertools
import logging
import time
import uuid
from collections.abc import Iterable
from typing import Any

import numpy as np
import orjson
import zenoh

from ..types.registry import UnknownType
from .action_interfaces import hidden_names
from .cdr import codec_for
from .core import Bus
from .errors import ServiceError
from .link import PARAM_SERVICES, RemoteGraph
from .services import (
    STATUS_ABORTED,
    STATUS_CANCELED,
    Action,
    GoalHandle,
    GoalOutcome,
    Service,
)
from .topics import Message, Origin
from .zenoh_keys import (
    NODE,
    PUBLISHER,
    SERVICE,
    SUBSCRIBER,
    Entity,
    data_key,
    pack_attachment,
    parse_token,
    qos_key,
    token,
)

log = logging.getLogger(__name__)

ACTION_SUFFIX = "/_action/send_goal"
LOCAL_ONLY = ("/rosapi/",)  # every server has its own rosapi
RESULT_WAIT = 24 * 3600.0  # a get_result query waits for the goal to finish


def session_config(
    config_file: str | None, connect: Iterable[str], listen: Iterable[str]
) -> zenoh.Config:
    """Peer mode, no multicast scouting, loopback unless told otherwise; a file replaces
    these defaults, explicit endpoints still apply on top of it."""
    try:
        config = zenoh.Config.from_file(config_file) if config_file else zenoh.Config()
    except zenoh.ZError as exc:
        raise ValueError(f"zenoh config {config_file}: {exc}") from None
    if not config_file:
        config.insert_json5("mode", '"peer"')
        config.insert_json5("scouting/multicast/enabled", "false")
        # Zenoh's own default listens on every interface; ours stays on loopback.
        listen = list(listen) or ["tcp/127.0.0.1:0"]
    try:
        for key, values in (("connect", list(connect)), ("listen", list(listen))):
            if values:
                config.insert_json5(f"{key}/endpoints", orjson.dumps(values).decode())
    except zenoh.ZError as exc:
        raise ValueError(f"zenoh endpoints: {exc}") from None
    return config


class ZenohLink:
    """Implements :class:`~hitrobot_server.bus.link.BusLink` over one Zenoh session."""

    def __init__(
        self,
        bus: Bus,
        *,
        domain: int = 0,
        config_file: str | None = None,
        connect: Iterable[str] = (),
        listen: Iterable[str] = (),
        shared_params: bool = False,
    ):
        self.bus = bus
        self.codec = codec_for(bus.types)
        self.shared_params = shared_params
        self.domain = domain
        self._config = session_config(config_file, connect, listen)
        self.session: zenoh.Session | None = None
        self.zid = ""
        self.loop: asyncio.AbstractEventLoop | None = None
        self._nids: dict[str, int] = {}
        self._eids = itertools.count(1)
        self._seq = itertools.count(1)
        self._tokens: dict[tuple[str, str, str], Any] = {}  # (kind, name, node) -> token
        self._subs: dict[str, tuple[str, Any]] = {}  # topic -> (key, zenoh subscriber)
        self._pubs: dict[str, tuple[str, Any, bytes]] = {}  # topic -> (key, publisher, gid)
        self._latch_q: dict[str, tuple[str, Any]] = {}
        self._served: dict[str, tuple[str, list[Any]]] = {}  # service/action -> queryables
        self._goals: dict[bytes, tuple[GoalHandle, asyncio.Task]] = {}  # served goals
        self._remote: dict[str, Entity] = {}  # token key -> entity of another process
        self._remote_subs: dict[str, int] = {}  # topic -> subscriptions in other processes
        self._graph: RemoteGraph | None = None
        self._watch = None
        self._feedback: dict[str, tuple[Any, dict[bytes, GoalHandle]]] = {}  # remote actions
        self._feedback_pubs: dict[str, Any] = {}  # local actions

    # ------------------------------------------------------------------ lifecycle
    async def start(self) -> None:
        self.loop = asyncio.get_running_loop()
        try:
            self.session = await asyncio.to_thread(zenoh.open, self._config)
        except zenoh.ZError as exc:
            raise OSError(f"zenoh: cannot open a session: {exc}") from None
        self.zid = str(self.session.zid())
        self._watch = self.session.liveliness().declare_subscriber(
            f"@ros2_lv/{self.domain}/**", self._on_token, history=True
        )
        self.bus.link = self
        for name in list(self.bus.nodes):
            self.changed("node", name)
        for kind, names in (
            ("topic", self.bus.topics),
            ("service", self.bus.services),
            ("action", self.bus.actions),
        ):
            for name in list(names):
                self.changed(kind, name)

    async def stop(self) -> None:
        if self.bus.link is self:
            self.bus.link = None
        for _handle, task in list(self._goals.values()):
            task.cancel()
        session, self.session = self.session, None
        if session is not None:
            await asyncio.to_thread(session.close)

    def _hop(self, fn, *args) -> None:
        """Run ``fn(*args)`` on the event loop (called from Zenoh's threads)."""
        loop = self.loop
        if loop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(fn, *args)

    # ------------------------------------------------------------------ discovery
    def _on_token(self, sample: zenoh.Sample) -> None:
        self._hop(self._token_event, str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)

    def _token_event(self, key: str, alive: bool) -> None:
        entity = parse_token(key)
        if entity is None or entity.zid == self.zid:
            return
        if alive:
            if key in self._remote:
                return
            self._remote[key] = entity
        elif self._remote.pop(key, None) is None:
            return
        self._graph = None
        if entity.kind == SUBSCRIBER:
            left = self._remote_subs.get(entity.name, 0) + (1 if alive else -1)
            if left > 0:
                self._remote_subs[entity.name] = left
            else:
                self._remote_subs.pop(entity.name, None)
        if alive and entity.kind == PUBLISHER and entity.latched:
            topic = self.bus.topics.get(entity.name)
            if topic is not None and topic.subscribers:
                topic.latched = True
                self._fetch_latched(topic.name)

    def graph(self) -> RemoteGraph:
        if self._graph is None:
            g = RemoteGraph()
            for e in self._remote.values():
                g.nodes.add(e.node)
                if e.kind in (PUBLISHER, SUBSCRIBER):
                    if "/_action/" in e.name:
                        continue
                    g.topics.setdefault(e.name, e.type_name)
                    side = g.publishers if e.kind == PUBLISHER else g.subscribers
                    side.setdefault(e.name, set()).add(e.node)
                elif e.kind == SERVICE:
                    if e.name.endswith(ACTION_SUFFIX):
                        g.actions[e.name[: -len(ACTION_SUFFIX)]] = (
                            e.type_name.removesuffix("_SendGoal"),
                            e.node,
                        )
                    elif "/_action/" not in e.name:
                        g.services[e.name] = (e.type_name, e.node)
            for action, (atype, node) in g.actions.items():  # listed as the local ones are
                services, topics = hidden_names(action, atype)
                g.services.update((n, (t, node)) for n, t in services.items())
                g.topics.update(topics)
                for topic in topics:
                    g.publishers.setdefault(topic, set()).add(node)
            self._graph = g
        return self._graph

    def _remote_of(self, kind: str, name: str) -> list[Entity]:
        return [e for e in self._remote.values() if e.kind == kind and e.name == name]

    def remote_type(self, topic: str) -> str | None:
        for e in self._remote.values():
            if e.name == topic and e.kind in (PUBLISHER, SUBSCRIBER) and e.type_name:
                return e.type_name if self.bus.types.has_msg(e.type_name) else None
        return None

    def _gid(self, *parts: str) -> bytes:
        return hashlib.blake2b("/".join((self.zid, *parts)).encode(), digest_size=16).digest()

    def _declare_token(self, kind: str, name: str, node: str, **endpoint: str) -> None:
        key = (kind, name, node)
        if key in self._tokens or self.session is None:
            return
        nid = self._nids.setdefault(node, len(self._nids))
        eid = nid if kind == NODE else next(self._eids) + 10_000
        expr = token(self.domain, self.zid, nid, eid, kind, node, name, **endpoint)
        try:
            self._tokens[key] = self.session.liveliness().declare_token(expr)
        except zenoh.ZError as exc:
            log.warning("zenoh: cannot announce %s %s: %s", kind, name, exc)

    def _sync_tokens(self, kind: str, name: str, nodes: set[str], **endpoint: str) -> None:
        for key in [k for k in self._tokens if k[0] == kind and k[1] == name]:
            if key[2] not in nodes:
                with contextlib.suppress(zenoh.ZError):
                    self._tokens.pop(key).undeclare()
        for node in nodes:
            self._declare_token(kind, name, node, **endpoint)

    def _local_only(self, name: str) -> bool:
        """Names that never cross: rosapi, except the parameters when they are shared (the
        workers of one ``--workers`` server: the process serving them keeps the only store)."""
        if self.shared_params and name in PARAM_SERVICES:
            return False
        return name.startswith(LOCAL_ONLY)

    # ------------------------------------------------------------------ local changes
    def changed(self, kind: str, name: str) -> None:
        if self.session is None or self._local_only(name):
            return
        if kind in ("topic", "service") and "/_action/" in name:
            return  # an action's own services/topics: the link exports the action itself
        if kind == "node":
            self._sync_tokens(NODE, name, {name} if name in self.bus.nodes else set())
        elif kind == "topic":
            self._sync_topic(name)
        elif kind == "service":
            self._sync_service(name)
        elif kind == "action":
            self._sync_action(name)

    def _sync_topic(self, name: str) -> None:
        topic = self.bus.topics.get(name)
        key = ""
        pubs: set[str] = set()
        subs: set[str] = set()
        if topic is not None:
            key = data_key(
                self.domain, name, topic.type_name, self.codec.type_hash(topic.type_name)
            )
            pubs = set(topic.publishers.values())
            subs = {node for node, _cb in topic.subscribers.values()}
        ep = {}
        if topic is not None:
            ep = {"type_name": topic.type_name, "type_hash": key.rsplit("/", 1)[1]}
        # Entities before tokens: whoever sees a token can already reach what it announces.
        self._sync_entity(self._pubs, name, key if pubs else "", self._declare_publisher)
        self._sync_entity(
            self._latch_q, name, key if pubs and topic.latched else "", self._declare_latch
        )
        self._sync_entity(self._subs, name, key if subs else "", self._declare_subscriber)
        self._sync_tokens(PUBLISHER, name, pubs, qos=qos_key(bool(topic and topic.latched)), **ep)
        self._sync_tokens(SUBSCRIBER, name, subs, qos=qos_key(), **ep)

    @staticmethod
    def _sync_entity(table: dict, name: str, key: str, declare) -> None:
        """Keep one Zenoh entity per name on ``key`` ("" = none)."""
        old = table.get(name)
        if old is not None and old[0] == key:
            return
        if old is not None:
            table.pop(name)
            with contextlib.suppress(zenoh.ZError):
                old[1].undeclare()
        if key:
            made = declare(name, key)
            if made is not None:
                table[name] = made

    def _declare_publisher(self, name: str, key: str):
        return key, self.session.declare_publisher(key), self._gid("pub", name)

    def _declare_latch(self, name: str, key: str):
        def on_query(query: zenoh.Query) -> None:
            self._hop(self._answer_latched, name, query)

        return key, self.session.declare_queryable(key, on_query)

    def _answer_latched(self, name: str, query: zenoh.Query) -> None:
        topic = self.bus.topics.get(name)
        try:
            if topic is not None and topic.last is not None and topic.last.origin is not _REMOTE:
                query.reply(query.key_expr, topic.last.cdr(self.codec))
        finally:
            query.drop()

    def _declare_subscriber(self, name: str, key: str):
        def on_sample(sample: zenoh.Sample) -> None:
            self._hop(self._deliver, name, sample.payload.to_bytes())

        sub = self.session.declare_subscriber(key, on_sample, allowed_origin=zenoh.Locality.REMOTE)
        self._fetch_latched(name)
        return key, sub

    def _fetch_latched(self, name: str) -> None:
        """Ask the other processes' latched publishers for their last message."""
        topic = self.bus.topics.get(name)
        if topic is None or self.session is None:
            return
        key = data_key(self.domain, name, topic.type_name, self.codec.type_hash(topic.type_name))

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                self._hop(self._deliver, name, reply.ok.payload.to_bytes(), True)

        self.session.get(
            key,
            on_reply,
            target=zenoh.QueryTarget.ALL,
            allowed_destination=zenoh.Locality.REMOTE,
            timeout=5.0,
        )

    def _deliver(self, name: str, payload: bytes, latched: bool = False) -> None:
        topic = self.bus.topics.get(name)
        if topic is None:
            return
        if latched:
            topic.latched = True
            if topic.last is not None:
                return  # a newer message already arrived
        try:
            msg = self.codec.decode(payload, topic.mtype)
        except Exception as exc:  # a foreign publisher with a different definition
            log.warning("zenoh: dropped a sample on %s: %s", name, exc)
            return
        message = Message(topic, msg, self.bus.clock(), None, _REMOTE)
        message.cdr_bytes = payload  # a recorder (bus tap) writes these very bytes
        topic.fan_out(message)
        for tap in self.bus.taps:
            tap.message(message)

    def published(self, message: Message) -> None:
        topic = message.topic
        pub = self._pubs.get(topic.name)
        if pub is None or topic.name not in self._remote_subs:
            return
        _key, publisher, gid = pub
        attachment = pack_attachment(next(self._seq), time.time_ns(), gid)
        try:
            publisher.put(message.cdr(self.codec), attachment=attachment)
        except Exception as exc:
            log.warning("zenoh: cannot send %s: %s", topic.name, exc)

    # ------------------------------------------------------------------ services
    def _serve(self, name: str, entries: list[tuple[str, str, Any]], node: str | None) -> None:
        """(Re)declare the queryables and SS tokens of one local service or action."""
        old = self._served.pop(name, None)
        if old is not None:
            for q in old[1]:
                with contextlib.suppress(zenoh.ZError):
                    q.undeclare()
        for sname, _stype, _h in entries:
            self._sync_tokens(SERVICE, sname, set())
        if node is None:
            return
        queryables = []
        for sname, stype, handler in entries:
            shash = self.codec.service_hash(stype)
            key = data_key(self.domain, sname, stype, shash)

            def on_query(query: zenoh.Query, handler=handler) -> None:
                self._hop(self._spawn_query, handler, query)

            queryables.append(self.session.declare_queryable(key, on_query, complete=True))
            self._sync_tokens(
                SERVICE, sname, {node}, type_name=stype, type_hash=shash, qos=qos_key()
            )
        self._served[name] = (node, queryables)

    def _spawn_query(self, handler, query: zenoh.Query) -> None:
        payload = query.payload.to_bytes() if query.payload is not None else b""
        asyncio.ensure_future(self._answer(handler, query, payload))

    async def _answer(self, handler, query: zenoh.Query, payload: bytes) -> None:
        try:
            data = await handler(payload)
            query.reply(query.key_expr, data)
        except ServiceError as exc:
            query.reply_err(str(exc))
        except Exception as exc:
            log.exception("zenoh: answering %s failed", query.key_expr)
            query.reply_err(f"{type(exc).__name__}: {exc}")
        finally:
            query.drop()

    def _sync_service(self, name: str) -> None:
        service = self.bus.services.get(name)
        if service is None:  # withdrawn: its queryable and its token go (as an action's do)
            self._serve(name, [(name, "", None)] if name in self._served else [], None)
            return
        stype = service.stype

        async def call(payload: bytes) -> bytes:
            request = self.codec.decode(payload, stype.request)
            response = await self.bus.call_service(name, request)
            return self.codec.encode(response, stype.response)

        self._serve(name, [(name, stype.name, call)], service.node)

    async def _get(self, key: str, payload: bytes, timeout: float | None, what: str) -> bytes:
        """One query to the (single) provider; ServiceError with the reason on failure."""
        assert self.loop is not None and self.session is not None
        done: asyncio.Future[bytes] = self.loop.create_future()

        def settle(ok: bytes | None, err: str | None) -> None:
            if done.done():
                return
            if ok is not None:
                done.set_result(ok)
            else:
                done.set_exception(ServiceError(err or f"{what}: no answer"))

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                self._hop(settle, reply.ok.payload.to_bytes(), None)
            else:
                self._hop(settle, None, reply.err.payload.to_string())

        def on_end() -> None:
            self._hop(settle, None, f"{what}: no answer (its server is gone or too slow)")

        attachment = pack_attachment(next(self._seq), time.time_ns(), self._gid("client", key))
        self.session.get(
            key,
            zenoh.handlers.Callback(on_reply, on_end),
            payload=payload,
            attachment=attachment,
            target=zenoh.QueryTarget.BEST_MATCHING,
            timeout=timeout if timeout and timeout > 0 else RESULT_WAIT,
        )
        return await done

    def _provider(self, name: str) -> Entity | None:
        found = self._remote_of(SERVICE, name)
        return found[0] if found else None

    def remote_service(self, name: str) -> Service | None:
        entity = self._provider(name)
        if entity is None or self._local_only(name):
            return None
        try:
            stype = self.bus.types.srv(entity.type_name)
        except UnknownType:
            return None
        key = data_key(self.domain, name, stype.name, entity.type_hash)

        async def handler(request: dict, timeout: float | None = None) -> dict:
            data = await self._get(
                key, self.codec.encode(request, stype.request), timeout, f"service '{name}'"
            )
            return self.codec.decode(data, stype.response)

        return Service(name, stype, _REMOTE_OWNER, entity.node, handler)

    # ------------------------------------------------------------------ actions
    def _sync_action(self, name: str) -> None:
        action = self.bus.actions.get(name)
        old = self._feedback_pubs.pop(name, None)
        if old is not None:
            with contextlib.suppress(zenoh.ZError):
                old.undeclare()
        if action is None:
            self._serve(name, self._action_entries(name, None), None)
            return
        self._serve(name, self._action_entries(name, action), action.node)

    def _action_entries(self, name: str, action: Action | None) -> list[tuple[str, str, Any]]:
        if action is None:
            old = self._served.get(name)
            return [] if old is None else [(f"{name}/_action/{p}", "", None) for p in _PARTS]
        atype = action.atype
        parts = self.codec.action_parts(atype)
        feedback_key = data_key(
            self.domain,
            f"{name}/_action/feedback",
            parts["feedback"],
            self.codec.type_hash(parts["feedback"]),
        )
        fb_pub = self._feedback_pubs[name] = self.session.declare_publisher(feedback_key)

        async def send_goal(payload: bytes) -> bytes:
            req = self.codec.decode_raw(payload, f"{parts['send_goal']}_Request")
            goal_id = bytes(req.goal_id.uuid)
            goal = self.codec.unwrap(req.goal, atype.goal)

            def on_feedback(values: dict) -> None:
                fb = self.codec.make(
                    parts["feedback"],
                    goal_id=req.goal_id,
                    feedback=self.codec.wrap(values, atype.feedback),
                )
                fb_pub.put(self.codec.encode_raw(fb, parts["feedback"]))

            handle, task = self.bus.start_goal(name, goal, on_feedback)
            self._goals[goal_id] = (handle, task)
            task.add_done_callback(
                lambda _t: self.loop.call_later(60, self._goals.pop, goal_id, None)
            )
            sec, nsec = divmod(time.time_ns(), 1_000_000_000)
            stamp = self.codec.make("builtin_interfaces/msg/Time", sec=sec, nanosec=nsec)
            resp = self.codec.make(f"{parts['send_goal']}_Response", accepted=True, stamp=stamp)
            return self.codec.encode_raw(resp, f"{parts['send_goal']}_Response")

        async def get_result(payload: bytes) -> bytes:
            req = self.codec.decode_raw(payload, f"{parts['get_result']}_Request")
            found = self._goals.get(bytes(req.goal_id.uuid))
            if found is None:
                raise ServiceError(f"action '{name}': unknown goal")
            out: GoalOutcome = await asyncio.shield(found[1])
            if isinstance(out.values, str):
                raise ServiceError(
                    orjson.dumps({"status": out.status, "text": out.values}).decode()
                )
            resp = self.codec.make(
                f"{parts['get_result']}_Response",
                status=out.status,
                result=self.codec.wrap(out.values, atype.result),
            )
            return self.codec.encode_raw(resp, f"{parts['get_result']}_Response")

        async def cancel_goal(payload: bytes) -> bytes:
            req = self.codec.decode_raw(payload, "action_msgs/srv/CancelGoal_Request")
            found = self._goals.get(bytes(req.goal_info.goal_id.uuid))
            if found is not None:
                found[0].cancel()
            resp = self.codec.make(
                "action_msgs/srv/CancelGoal_Response",
                return_code=0 if found is not None else 2,
                goals_canceling=[req.goal_info] if found is not None else [],
            )
            return self.codec.encode_raw(resp, "action_msgs/srv/CancelGoal_Response")

        return [
            (f"{name}/_action/send_goal", parts["send_goal"], send_goal),
            (f"{name}/_action/get_result", parts["get_result"], get_result),
            (f"{name}/_action/cancel_goal", parts["cancel_goal"], cancel_goal),
        ]

    def remote_action(self, name: str) -> Action | None:
        entity = self._provider(f"{name}{ACTION_SUFFIX}")
        if entity is None:
            return None
        try:
            atype = self.bus.types.action(entity.type_name.removesuffix("_SendGoal"))
        except UnknownType:
            return None
        parts = self.codec.action_parts(atype)
        keys = {
            p: data_key(
                self.domain, f"{name}/_action/{p}", parts[p], self.codec.service_hash(parts[p])
            )
            for p in _PARTS
        }
        waiting = self._feedback_table(name, parts["feedback"], atype)

        async def handler(handle: GoalHandle) -> GoalOutcome:
            goal_id = self.codec.make("unique_identifier_msgs/msg/UUID", uuid=_uuid_array())
            gid = bytes(goal_id.uuid)
            waiting[gid] = handle
            what = f"action '{name}'"
            accepted: asyncio.Future[bool] = asyncio.get_running_loop().create_future()

            async def send_cancel() -> None:
                if not await accepted:  # a cancel before the goal's reply waits for it
                    return
                info = self.codec.make(
                    "action_msgs/msg/GoalInfo",
                    goal_id=goal_id,
                    stamp=self.codec.make("builtin_interfaces/msg/Time", sec=0, nanosec=0),
                )
                req = self.codec.make("action_msgs/srv/CancelGoal_Request", goal_info=info)
                raw = self.codec.encode_raw(req, "action_msgs/srv/CancelGoal_Request")
                with contextlib.suppress(ServiceError):
                    await self._get(keys["cancel_goal"], raw, 10.0, what)

            handle.on_cancel.append(lambda: asyncio.ensure_future(send_cancel()))
            try:
                req = self.codec.make(
                    f"{parts['send_goal']}_Request",
                    goal_id=goal_id,
                    goal=self.codec.wrap(handle.goal, atype.goal),
                )
                data = await self._get(
                    keys["send_goal"],
                    self.codec.encode_raw(req, f"{parts['send_goal']}_Request"),
                    30.0,
                    what,
                )
                ok = self.codec.decode_raw(data, f"{parts['send_goal']}_Response").accepted
                accepted.set_result(bool(ok))
                if not ok:
                    return GoalOutcome(STATUS_ABORTED, f"{what}: goal rejected", False)
                req = self.codec.make(f"{parts['get_result']}_Request", goal_id=goal_id)
                raw = self.codec.encode_raw(req, f"{parts['get_result']}_Request")
                try:
                    data = await self._get(keys["get_result"], raw, None, what)
                except ServiceError as exc:
                    try:
                        err = orjson.loads(str(exc))
                        return GoalOutcome(int(err["status"]), str(err["text"]), False)
                    except (orjson.JSONDecodeError, KeyError, TypeError):
                        return GoalOutcome(STATUS_ABORTED, str(exc), False)
                resp = self.codec.decode_raw(data, f"{parts['get_result']}_Response")
                values = self.codec.unwrap(resp.result, atype.result)
                return GoalOutcome(int(resp.status), values, True)
            except ServiceError as exc:
                status = STATUS_CANCELED if handle.cancelled.is_set() else STATUS_ABORTED
                return GoalOutcome(status, str(exc), False)
            finally:
                waiting.pop(gid, None)
                if not accepted.done():
                    accepted.set_result(False)

        return Action(name, atype, _REMOTE_OWNER, entity.node, handler)

    def _feedback_table(self, name: str, fb_type: str, atype) -> dict[bytes, GoalHandle]:
        found = self._feedback.get(name)
        if found is not None:
            return found[1]
        waiting: dict[bytes, GoalHandle] = {}
        key = data_key(
            self.domain, f"{name}/_action/feedback", fb_type, self.codec.type_hash(fb_type)
        )

        def deliver(payload: bytes) -> None:
            try:
                fb = self.codec.decode_raw(payload, fb_type)
            except Exception as exc:
                log.warning("zenoh: bad feedback on %s: %s", name, exc)
                return
            handle = waiting.get(bytes(fb.goal_id.uuid))
            if handle is not None:
                handle.feedback(self.codec.unwrap(fb.feedback, atype.feedback))

        sub = self.session.declare_subscriber(
            key,
            lambda s: self._hop(deliver, s.payload.to_bytes()),
            allowed_origin=zenoh.Locality.REMOTE,
        )
        self._feedback[name] = (sub, waiting)
        return waiting


_PARTS = ("send_goal", "get_result", "cancel_goal")
_REMOTE = Origin("/zenoh")
_REMOTE_OWNER = object()


def _uuid_array() -> np.ndarray:
    return np.frombuffer(uuid.uuid4().bytes, dtype=np.uint8).copy()

"""Topics across processes: local publishers and subscribers as Zenoh ones (with ``MP`` /
``MS`` tokens), remote samples fanned out locally, latched topics answered and fetched."""

from __future__ import annotations

import contextlib
import logging
from typing import Any

import zenoh

from ..topics import Message
from .keys import PUBLISHER, SUBSCRIBER, Entity, qos_key
from .peer import REMOTE, Peer

log = logging.getLogger(__name__)


class TopicBridge:
    """Keeps one topic's Zenoh publisher, latch queryable, subscriber and tokens in step with
    the local topic, and counts the other processes' subscriptions."""

    def __init__(self, peer: Peer):
        self.peer = peer
        self._subs: dict[str, tuple[str, Any]] = {}  # topic -> (key, zenoh subscriber)
        self._pubs: dict[str, tuple[str, Any, bytes]] = {}  # topic -> (key, publisher, gid)
        self._latch_q: dict[str, tuple[str, Any]] = {}
        self._remote_subs: dict[str, int] = {}  # topic -> subscriptions in other processes

    def _key(self, name: str, type_name: str) -> str:
        return self.peer.key(name, type_name, self.peer.codec.type_hash(type_name))

    def remote_changed(self, entity: Entity, alive: bool) -> None:
        """Another process's entity came or went."""
        if entity.kind == SUBSCRIBER:
            left = self._remote_subs.get(entity.name, 0) + (1 if alive else -1)
            if left > 0:
                self._remote_subs[entity.name] = left
            else:
                self._remote_subs.pop(entity.name, None)
        if alive and entity.kind == PUBLISHER and entity.latched:
            topic = self.peer.bus.topics.get(entity.name)
            if topic is not None and topic.subscribers:
                topic.latched = True
                self._fetch_latched(topic.name)

    def sync(self, name: str) -> None:
        topic = self.peer.bus.topics.get(name)
        key = ""
        pubs: set[str] = set()
        subs: set[str] = set()
        if topic is not None:
            key = self._key(name, topic.type_name)
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
        latched = bool(topic and topic.latched)
        self.peer.sync_tokens(PUBLISHER, name, pubs, qos=qos_key(latched), **ep)
        self.peer.sync_tokens(SUBSCRIBER, name, subs, qos=qos_key(), **ep)

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
        return key, self.peer.session.declare_publisher(key), self.peer.gid("pub", name)

    def _declare_latch(self, name: str, key: str):
        def on_query(query: zenoh.Query) -> None:
            self.peer.hop(self._answer_latched, name, query)

        return key, self.peer.session.declare_queryable(key, on_query)

    def _answer_latched(self, name: str, query: zenoh.Query) -> None:
        topic = self.peer.bus.topics.get(name)
        try:
            if topic is not None and topic.last is not None and topic.last.origin is not REMOTE:
                query.reply(query.key_expr, topic.last.cdr(self.peer.codec))
        finally:
            query.drop()

    def _declare_subscriber(self, name: str, key: str):
        def on_sample(sample: zenoh.Sample) -> None:
            self.peer.hop(self._deliver, name, sample.payload.to_bytes())

        sub = self.peer.session.declare_subscriber(
            key, on_sample, allowed_origin=zenoh.Locality.REMOTE
        )
        self._fetch_latched(name)
        return key, sub

    def _fetch_latched(self, name: str) -> None:
        """Ask the other processes' latched publishers for their last message."""
        topic = self.peer.bus.topics.get(name)
        if topic is None or self.peer.session is None:
            return
        key = self._key(name, topic.type_name)

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                self.peer.hop(self._deliver, name, reply.ok.payload.to_bytes(), True)

        self.peer.session.get(
            key,
            on_reply,
            target=zenoh.QueryTarget.ALL,
            allowed_destination=zenoh.Locality.REMOTE,
            timeout=5.0,
        )

    def _deliver(self, name: str, payload: bytes, latched: bool = False) -> None:
        bus = self.peer.bus
        topic = bus.topics.get(name)
        if topic is None:
            return
        if latched:
            topic.latched = True
            if topic.last is not None:
                return  # a newer message already arrived
        try:
            msg = self.peer.codec.decode(payload, topic.mtype)
        except Exception as exc:  # a foreign publisher with a different definition
            log.warning("zenoh: dropped a sample on %s: %s", name, exc)
            return
        message = Message(topic, msg, bus.clock(), None, REMOTE)
        message.cdr_bytes = payload  # a recorder (bus tap) writes these very bytes
        if not topic.fan_out(message):  # the topic's guard refused it
            return
        for tap in bus.taps:
            tap.message(message)

    def published(self, message: Message) -> None:
        topic = message.topic
        pub = self._pubs.get(topic.name)
        if pub is None or topic.name not in self._remote_subs:
            return
        _key, publisher, gid = pub
        attachment = self.peer.attachment(gid)
        try:
            publisher.put(message.cdr(self.peer.codec), attachment=attachment)
        except Exception as exc:
            log.warning("zenoh: cannot send %s: %s", topic.name, exc)

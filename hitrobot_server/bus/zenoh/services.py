"""Services across processes: a local service (or an action's three services) served as
queryables with ``SS`` tokens; a call that misses locally becomes a query to the provider."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import Any

import zenoh

from ...types.registry import UnknownType
from ..errors import ServiceError
from ..services import Service
from .graph import RemoteEntities
from .keys import SERVICE, qos_key
from .peer import REMOTE_OWNER, Peer

log = logging.getLogger(__name__)

Handler = Callable[[bytes], Awaitable[bytes]]
Entry = tuple[str, str, Any]  # (service name, service type, Handler or None)


class ServiceBridge:
    """Serves the local services to the other processes and proxies theirs."""

    def __init__(self, peer: Peer, remote: RemoteEntities):
        self.peer = peer
        self.remote = remote
        self._served: dict[str, tuple[str, list[Any]]] = {}  # service/action -> queryables

    def serving(self, name: str) -> bool:
        return name in self._served

    def serve(self, name: str, entries: list[Entry], node: str | None) -> None:
        """(Re)declare the queryables and SS tokens of one local service or action."""
        old = self._served.pop(name, None)
        if old is not None:
            for q in old[1]:
                with contextlib.suppress(zenoh.ZError):
                    q.undeclare()
        for sname, _stype, _h in entries:
            self.peer.sync_tokens(SERVICE, sname, set())
        if node is None:
            return
        queryables = []
        for sname, stype, handler in entries:
            shash = self.peer.codec.service_hash(stype)
            key = self.peer.key(sname, stype, shash)

            def on_query(query: zenoh.Query, handler=handler) -> None:
                self.peer.hop(self._spawn_query, handler, query)

            queryables.append(self.peer.session.declare_queryable(key, on_query, complete=True))
            self.peer.sync_tokens(
                SERVICE, sname, {node}, type_name=stype, type_hash=shash, qos=qos_key()
            )
        self._served[name] = (node, queryables)

    def _spawn_query(self, handler: Handler, query: zenoh.Query) -> None:
        payload = query.payload.to_bytes() if query.payload is not None else b""
        asyncio.ensure_future(self._answer(handler, query, payload))

    async def _answer(self, handler: Handler, query: zenoh.Query, payload: bytes) -> None:
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

    def sync(self, name: str) -> None:
        bus, codec = self.peer.bus, self.peer.codec
        service = bus.services.get(name)
        if service is None:  # withdrawn: its queryable and its token go (as an action's do)
            self.serve(name, [(name, "", None)] if name in self._served else [], None)
            return
        stype = service.stype

        async def call(payload: bytes) -> bytes:
            request = codec.decode(payload, stype.request)
            response = await bus.call_service(name, request)
            return codec.encode(response, stype.response)

        self.serve(name, [(name, stype.name, call)], service.node)

    def remote_service(self, name: str) -> Service | None:
        entity = self.remote.provider(name)
        if entity is None or self.peer.local_only(name):
            return None
        try:
            stype = self.peer.bus.types.srv(entity.type_name)
        except UnknownType:
            return None
        key = self.peer.key(name, stype.name, entity.type_hash)
        peer, codec = self.peer, self.peer.codec

        async def handler(request: dict, timeout: float | None = None) -> dict:
            data = await peer.get(
                key, codec.encode(request, stype.request), timeout, f"service '{name}'"
            )
            return codec.decode(data, stype.response)

        return Service(name, stype, REMOTE_OWNER, entity.node, handler)

"""Service ops: calling bus services, and serving bus calls from this client."""

from __future__ import annotations

import asyncio
import itertools
import math
from typing import TYPE_CHECKING, Any

from ..bus.errors import ServiceError
from ..bus.names import canonical, valid_name
from ..protocol.errors import ProtocolError
from ..protocol.ops import COMPRESSIONS
from ..types.convert import ConversionError, from_json
from ..types.registry import MsgType

if TYPE_CHECKING:
    from .session import Session


def split_id(name: str, op_id: Any) -> tuple[str, Any]:
    """Honour the deprecated ``"/name#ID"`` spelling when no ``id`` is given."""
    if "#" in name:
        name, _, suffix = name.partition("#")
        if op_id is None:
            op_id = suffix
    return name, op_id


def args_to_request(op: str, mtype: MsgType, args: Any, session: Session, op_id: Any) -> dict:
    """``args`` as object, list (zipped with the request fields) or null → a request message."""
    if args is None:
        args = {}
    elif isinstance(args, list):
        if len(args) > len(mtype.fields):
            raise ProtocolError(
                f"{op}: field 'args' has {len(args)} values but {session.types.short(mtype.name)} "
                f"has {len(mtype.fields)} field(s)",
                op_id,
            )
        args = {f.name: v for f, v in zip(mtype.fields, args, strict=False)}
    try:
        value, missing = from_json(mtype, args, session.types)
    except ConversionError as exc:
        raise ProtocolError(f"{op}: field 'args': {exc}", op_id) from None
    if missing:
        session.status("warning", f"{op}: args lack field(s) {', '.join(missing)}", op_id)
    return value


class ServiceOps:
    def __init__(self, session: Session):
        self.session = session
        self.provided: set[str] = set()
        self.pending: dict[str, tuple[asyncio.Future, MsgType, str]] = {}
        self._counters: dict[str, itertools.count] = {}

    # ------------------------------------------------------------- calling
    def call_service(self, msg: dict) -> None:
        s = self.session
        service_str, op_id = split_id(msg["service"], msg.get("id"))
        name = canonical(service_str)
        if not valid_name(service_str):
            raise ProtocolError(
                f"call_service: field 'service' is not a valid name: {service_str!r}", op_id
            )
        reply = {"op": "service_response", "service": msg["service"]}
        if op_id is not None:
            reply["id"] = op_id
        frag = msg.get("fragment_size")
        compression = msg.get("compression") or "none"

        def fail(text: str) -> None:
            s.send({**reply, "values": text, "result": False}, fragment_size=frag)
            s.status("error", f"call_service: {text}", op_id)

        if compression not in COMPRESSIONS:
            fail(f"field 'compression' must be one of {', '.join(COMPRESSIONS)}, "
                 f"got {compression!r}")
            return
        if compression not in ("none", "png"):
            compression = "none"  # binary service replies would break JSON-only clients
        timeout = msg.get("timeout")
        if timeout is not None and not (math.isfinite(timeout) and timeout >= 0):
            fail(f"field 'timeout' must be a finite number of seconds, 0 or more, got {timeout}")
            return

        if not s.settings.services_filter.allows(name):
            fail(f"service '{name}' is not allowed by --services-glob")
            return
        service = s.bus.service(name)
        if service is None:
            fail(f"service '{name}' does not exist")
            return
        try:
            request = args_to_request(
                "call_service", service.stype.request, msg.get("args"), s, op_id
            )
        except ProtocolError as exc:
            fail(exc.msg.removeprefix("call_service: "))
            return
        if timeout is None:
            timeout = s.settings.call_service_timeout

        async def run() -> None:
            try:
                try:
                    values = await s.bus.call_service(name, request, timeout)
                finally:
                    s.calls_in_flight -= 1
            except ServiceError as exc:
                if exc.values is not None:  # the provider's own failure values, as rosbridge
                    s.send({**reply, "values": exc.values, "result": False}, fragment_size=frag)
                else:
                    fail(str(exc))
                return
            s.send(
                {**reply, "values": values, "result": True},
                fragment_size=frag,
                compression=compression,
            )

        s.calls_in_flight += 1  # counted toward the reply budget (session._replies_full)
        s.spawn(run())

    # ------------------------------------------------------------- providing
    def advertise_service(self, msg: dict) -> None:
        s = self.session
        op_id = msg.get("id")
        service_str = msg["service"]
        if not valid_name(service_str):
            raise ProtocolError(
                f"advertise_service: field 'service' is not a valid name: {service_str!r}", op_id
            )
        name = canonical(service_str)
        if not s.settings.services_filter.allows(name):
            raise ProtocolError(
                f"advertise_service: service '{name}' is not allowed by --services-glob", op_id
            )
        counter = self._counters.setdefault(name, itertools.count(1))

        async def handler(request: dict) -> dict:
            rid = f"service_request:{name}:{next(counter)}"
            fut = asyncio.get_running_loop().create_future()
            self.pending[rid] = (fut, service.stype.response, name)
            s.send({"op": "call_service", "id": rid, "service": name, "args": request})
            try:
                return await fut
            finally:
                self.pending.pop(rid, None)

        service = s.bus.advertise_service(name, msg["type"], s, s.node, handler, client=True)
        self.provided.add(name)
        s.status("info", f"advertised service '{name}'", op_id)

    def unadvertise_service(self, msg: dict) -> None:
        s = self.session
        name = canonical(msg["service"])
        if name not in self.provided or not s.bus.unadvertise_service(name, s):
            self.provided.discard(name)
            raise ProtocolError(
                f"unadvertise_service: service '{name}' is not advertised by you", msg.get("id")
            )
        self.provided.discard(name)
        self._fail_pending(name, f"service '{name}' was unadvertised")
        s.status("info", f"unadvertised service '{name}'", msg.get("id"))

    def service_response(self, msg: dict) -> None:
        s = self.session
        rid = msg["id"]
        entry = self.pending.get(rid) if isinstance(rid, str) else None
        if entry is None:
            raise ProtocolError(f"service_response: no pending request with id {rid!r}", rid)
        fut, mtype, name = entry
        if fut.done():
            return
        values = msg.get("values")
        if msg["result"] is False and not isinstance(values, dict):
            text = (
                values
                if isinstance(values, str) and values
                else (f"service '{name}' failed (the provider answered result:false)")
            )
            fut.set_exception(ServiceError(text))
            return
        try:
            value, _missing = from_json(mtype, values or {}, s.types)
        except ConversionError as exc:
            fut.set_exception(ServiceError(f"service '{name}' sent an invalid response: {exc}"))
            raise ProtocolError(f"service_response: field 'values': {exc}", rid) from None
        if msg["result"] is False:
            fut.set_exception(ServiceError(f"service '{name}' answered result:false", value))
        else:
            fut.set_result(value)

    def invalid_response(self, obj: object, text: str) -> None:
        """A ``service_response`` too malformed to run (``result: null``, no ``result``) still
        answers the call it names: the caller gets a failed response, never silence."""
        if not isinstance(obj, dict) or obj.get("op") != "service_response":
            return
        rid = obj.get("id")
        entry = self.pending.get(rid) if isinstance(rid, str) else None
        if entry is not None and not entry[0].done():
            entry[0].set_exception(
                ServiceError(f"service '{entry[2]}' sent an invalid response: {text}"))

    def _fail_pending(self, name: str | None, text: str) -> None:
        for _rid, (fut, _mtype, svc) in list(self.pending.items()):
            if (name is None or svc == name) and not fut.done():
                fut.set_exception(ServiceError(text))

    def close(self) -> None:
        """A provider that disconnects fails its pending calls; its services disappear."""
        self._fail_pending(None, f"the provider of this service ({self.session.node}) disconnected")
        for name in list(self.provided):
            self.session.bus.unadvertise_service(name, self.session)
        self.provided.clear()

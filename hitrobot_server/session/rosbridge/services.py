"""Service ops: calling bus services, and serving bus calls from this client."""

from __future__ import annotations

import asyncio
import functools
import itertools
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ...bus.errors import ServiceError
from ...bus.names import canonical, valid_name
from ...protocol import ops
from ...protocol.errors import MessageId, ProtocolError
from ...protocol.ops import (
    COMPRESSIONS,
    AdvertiseService,
    CallService,
    ServiceResponse,
    UnadvertiseService,
)
from ...types.convert import ConversionError, from_json
from ...types.generation import is_ros2, ros2_times
from ...types.registry import MsgType, TypeRegistry

if TYPE_CHECKING:
    from .context import OpContext

Reply = Callable[[Any, bool], dict]
"""A ``service_response`` to one call, of its values and result (``ops.service_response``
with the call's service and id)."""


def split_id(name: str, op_id: MessageId) -> tuple[str, MessageId]:
    """Honour the deprecated ``"/name#ID"`` spelling when no ``id`` is given."""
    if "#" in name:
        name, _, suffix = name.partition("#")
        if op_id is None:
            op_id = suffix
    return name, op_id


def args_to_request(
    op: str, mtype: MsgType, args: dict | list | None, client: OpContext, op_id: MessageId
) -> dict:
    """``args`` as object, list (zipped with the request fields) or null → a request message."""
    if args is None:
        args = {}
    elif isinstance(args, list):
        if len(args) > len(mtype.fields):
            raise ProtocolError(
                f"{op}: field 'args' has {len(args)} values but "
                f"{client.bus.types.short(mtype.name)} has {len(mtype.fields)} field(s)",
                op_id,
            )
        args = {f.name: v for f, v in zip(mtype.fields, args, strict=False)}
    try:
        value, missing = from_json(mtype, args, client.bus.types)
    except ConversionError as exc:
        raise ProtocolError(f"{op}: field 'args': {exc}", op_id) from None
    if missing:
        client.status("warning", f"{op}: args lack field(s) {', '.join(missing)}", op_id)
    return value


def too_many_in_flight(limit: int, what: str) -> str:
    """The refusal of a request beyond the per-client cap (``--max-requests-in-flight``)."""
    return (f"too many requests in flight: {limit} {what} of this client are still waiting "
            "for an answer (--max-requests-in-flight)")


class ServiceOps:
    def __init__(self, client: OpContext):
        self.client = client
        self.provided: set[str] = set()
        self.pending: dict[str, tuple[asyncio.Future, MsgType, str]] = {}
        self._counters: dict[str, itertools.count] = {}
        self.in_flight = 0  # this client's calls waiting for their answer

    # ------------------------------------------------------------- calling
    def call_service(self, op: CallService) -> None:
        c = self.client
        service_str, op_id = split_id(op.service, op.id)
        name = canonical(service_str)
        if not valid_name(service_str):
            raise ProtocolError(
                f"call_service: field 'service' is not a valid name: {service_str!r}", op_id
            )
        reply = functools.partial(ops.service_response, op.service, op_id)
        frag = c.fragment_size(op)

        def fail(text: str) -> None:
            c.send(reply(text, False), fragment_size=frag)
            c.status("error", f"call_service: {text}", op_id)

        limit = c.settings.max_requests_in_flight
        compression = op.compression or "none"
        timeout = op.timeout  # a number (the spec's check), but NaN and < 0 get here too
        if self.in_flight >= limit:
            return fail(too_many_in_flight(limit, "service calls"))
        if compression not in COMPRESSIONS:
            return fail(f"field 'compression' must be one of {', '.join(COMPRESSIONS)}, "
                        f"got {compression!r}")
        if timeout is not None and not (math.isfinite(timeout) and timeout >= 0):
            return fail(f"field 'timeout' must be a finite number of seconds, 0 or more, "
                        f"got {timeout}")
        if not c.settings.services_filter.allows(name):
            return fail(f"service '{name}' is not allowed by --services-glob")
        service = c.bus.service(name)
        if service is None:
            return fail(f"service '{name}' does not exist")
        try:
            request = args_to_request("call_service", service.stype.request, op.args, c, op_id)
        except ProtocolError as exc:
            return fail(exc.msg.removeprefix("call_service: "))
        if timeout is None:
            timeout = c.settings.call_service_timeout
        if is_ros2(service.stype.name):  # its times as ROS 2 spells them (types/generation.py)
            reply = _ros2_reply(reply, service.stype.response, c.bus.types)
        c.bus.client_called("call_service", name, c.origin)
        self.in_flight += 1
        # binary service replies would break JSON-only clients
        c.spawn(self._call(name, request, timeout, reply, frag,
                           "png" if compression == "png" else "none", fail))

    async def _call(self, name: str, request: dict, timeout: float, reply: Reply,
                    frag: int | None, compression: str, fail: Callable[[str], None]) -> None:
        """The call itself, answered with the provider's values (or its failure)."""
        c = self.client
        try:
            values = await c.bus.call_service(name, request, timeout, c.origin)
        except ServiceError as exc:
            fail(str(exc))
            return
        finally:
            self.in_flight -= 1
        c.send(reply(values, True), fragment_size=frag, compression=compression)

    # ------------------------------------------------------------- providing
    def advertise_service(self, op: AdvertiseService) -> None:
        c = self.client
        op_id = op.id
        service_str = op.service
        if not valid_name(service_str):
            raise ProtocolError(
                f"advertise_service: field 'service' is not a valid name: {service_str!r}", op_id
            )
        name = canonical(service_str)
        if not c.settings.services_filter.allows(name):
            raise ProtocolError(
                f"advertise_service: service '{name}' is not allowed by --services-glob", op_id
            )
        counter = self._counters.setdefault(name, itertools.count(1))

        async def handler(request: dict) -> dict:
            rid = f"service_request:{name}:{next(counter)}"
            fut = asyncio.get_running_loop().create_future()
            self.pending[rid] = (fut, service.stype.response, name)
            c.send(ops.call_service(rid, name, request))
            try:
                return await fut
            finally:
                self.pending.pop(rid, None)

        service = c.bus.advertise_service(name, op.type, c, c.node, handler, client=True)
        self.provided.add(name)
        c.status("info", f"advertised service '{name}'", op_id)

    def unadvertise_service(self, op: UnadvertiseService) -> None:
        c = self.client
        name = canonical(op.service)
        if name not in self.provided or not c.bus.unadvertise_service(name, c):
            self.provided.discard(name)
            raise ProtocolError(
                f"unadvertise_service: service '{name}' is not advertised by you", op.id
            )
        self.provided.discard(name)
        self._fail_pending(name, f"service '{name}' was unadvertised")
        c.status("info", f"unadvertised service '{name}'", op.id)

    def service_response(self, op: ServiceResponse) -> None:
        """A provider's answer. As rosbridge, its ``result`` is not passed on: values that
        convert are the caller's successful answer, ``result: false`` or not; only a failure
        without values (or with values that do not convert) fails the call."""
        rid = op.id
        entry = self.pending.get(rid)  # a string or an integer: the spec's check
        if entry is None:
            raise ProtocolError(f"service_response: no pending request with id {rid!r}", rid)
        fut, mtype, name = entry
        if fut.done():
            return
        values = op.values
        if not op.result and not isinstance(values, dict):
            text = (
                values
                if isinstance(values, str) and values
                else (f"service '{name}' failed (the provider answered result:false)")
            )
            fut.set_exception(ServiceError(text))
            return
        try:
            value, _missing = from_json(mtype, values or {}, self.client.bus.types)
        except ConversionError as exc:
            fut.set_exception(ServiceError(f"service '{name}' sent an invalid response: {exc}"))
            raise ProtocolError(f"service_response: field 'values': {exc}", rid) from None
        fut.set_result(value)  # a provider's result:false with its values: as rosbridge, ignored

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
        self._fail_pending(None, f"the provider of this service ({self.client.node}) disconnected")
        for name in list(self.provided):
            self.client.bus.unadvertise_service(name, self.client)
        self.provided.clear()


def _ros2_reply(reply: Reply, response: MsgType, types: TypeRegistry) -> Reply:
    """``reply`` with a ROS 2 type's times spelled ``{sec, nanosec}`` in its values."""
    def spelled(values: Any, result: bool) -> dict:
        return reply(ros2_times(values, response, types) if result else values, result)
    return spelled

"""Service calls: a binary request on an advertised service, answered by the bus's provider."""

from __future__ import annotations

import asyncio
import logging
from typing import TYPE_CHECKING

from ...bus.errors import BusError
from ...protocol import foxglove as fg
from ...types.registry import SrvType
from .frames import decode_cdr

if TYPE_CHECKING:
    from .context import FoxgloveContext

log = logging.getLogger(__name__)

MAX_CALLS = 64
"""Most service calls of one client waiting for their provider at once."""


class ServiceOps:
    def __init__(self, client: FoxgloveContext, services: dict[int, tuple[str, SrvType]]):
        self.client = client
        self.services = services  # the services advertised to this client (id → name, type)
        self.tasks: set[asyncio.Task] = set()  # the calls waiting for their answers (counted;
        # the client core cancels them when the client goes)

    def call(self, req: fg.ServiceCallRequest) -> None:
        entry = self.services.get(req.service_id)
        if entry is None:
            self._failed(req, f"unknown service id {req.service_id}")
            return
        name, stype = entry
        limit = min(MAX_CALLS, self.client.settings.max_requests_in_flight)
        if len(self.tasks) >= limit:
            self._failed(req, f"{limit} calls of this client are already waiting for "
                         "their answers")
            return
        out = self.client.out
        if out.full:
            self._failed(req, f"too many requests in flight: {out.outbox.control_bytes} bytes "
                         f"of replies not read yet (--reply-buffer-limit {out.reply_limit}); "
                         "refused")
            return
        if req.encoding != fg.ENCODING:
            self._failed(req, f"encoding {req.encoding!r:.40} is not supported "
                         f"(only '{fg.ENCODING}')")
            return
        try:
            request = decode_cdr(self.client.codec, req.payload, stype.request)
        except Exception as exc:
            self._failed(req, f"the request CDR does not match {stype.request.name}: {exc}")
            return
        task = self.client.spawn(self._call(req, name, stype, request))
        self.tasks.add(task)
        task.add_done_callback(self.tasks.discard)

    async def _call(self, req: fg.ServiceCallRequest, name: str, stype: SrvType,
                    request: dict) -> None:
        c = self.client
        try:
            response = await c.bus.call_service(name, request, c.settings.call_service_timeout,
                                               c.origin)
            payload = c.codec.encode(response, stype.response)
        except BusError as exc:
            c.out.send(fg.service_call_failure(req.service_id, req.call_id, str(exc)))
            return
        except Exception as exc:
            log.exception("foxglove client %s: service %s failed", c.node, name)
            c.out.send(fg.service_call_failure(req.service_id, req.call_id,
                                               f"service '{name}' failed: {exc}"))
            return
        c.out.binary(fg.service_call_response(req.service_id, req.call_id, fg.ENCODING,
                                              payload))

    def _failed(self, req: fg.ServiceCallRequest, text: str) -> None:
        self.client.out.status(fg.ERROR, f"service call request {req.call_id}: {text}")
        self.client.out.send(fg.service_call_failure(req.service_id, req.call_id, text))

"""A node's sections of the robot's state store: what the operator built survives restarts.

Nodes put a section whenever it changes and await :meth:`NodeMemory.durable` before they
acknowledge the request, so an acknowledged change is on disk; when it could not be written
(disk full) ``durable`` raises :class:`NotSaved`, a service error, so a service answers it as
a failure, and a node that can takes its change back from :meth:`NodeMemory.get` (the store
answers what is on disk again). Without a binding (tests of a
node alone) everything is a no-op; with a binding whose store is not known yet (a REST robot
not reached so far) a change is only noted, and the server settles it once the robot is known.

When an answer waits for that is the table of :mod:`.acks`, applied here: :func:`acknowledged`
wraps a service, :func:`kept` waits for a request answered otherwise.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from ...bus.errors import ServiceError
from ...state import StateBinding, StateStore, StateWriteError
from .acks import ACKS, KEPT

log = logging.getLogger(__name__)


class NotSaved(ServiceError):
    """A change that did not reach the state folder: refuse the request that made it."""


class NodeMemory:
    """The sections ``<prefix>/<name>`` of one store."""

    def __init__(self, binding: StateBinding | None, prefix: str) -> None:
        self.binding = binding
        self.prefix = prefix
        self._pending: asyncio.Future | None = None

    @property
    def store(self) -> StateStore | None:
        return None if self.binding is None else self.binding.store

    def get(self, name: str) -> Any:
        return None if self.store is None else self.store.get(f"{self.prefix}/{name}")

    def reject(self, name: str, reason: str) -> None:
        """A restored section could not be used: logged and kept aside by the store."""
        if self.store is not None:
            self.store.reject(f"{self.prefix}/{name}", reason)

    def put(self, name: str, value: Any) -> None:
        if self.store is not None:
            self._pending = self.store.put(f"{self.prefix}/{name}", value)
        elif self.binding is not None:
            self.binding.changed_unbound = True

    async def durable(self) -> None:
        """Wait until every section put so far is on disk; :class:`NotSaved` (the store's
        reason: ``not saved to the state folder: disk full``) when it could not be written."""
        pending = self._pending  # the latest put: its batch comes after every earlier one
        if pending is not None:
            try:
                await asyncio.shield(pending)
            except StateWriteError as exc:
                log.error("%s: %s", self.prefix, exc)
                raise NotSaved(str(exc)) from None


Handler = Callable[[dict], Awaitable[dict]]
Keeping = Callable[[], Awaitable[str]]
"""Awaits until every change so far is kept: "" when it is, else what is missing (said in the
reply); raises ``NotSaved`` when the disk refused it."""


def waits(name: str) -> bool:
    """Whether ``name``'s answer waits for its change to be kept (ValueError: not listed)."""
    try:
        rule = ACKS[name]
    except KeyError:
        raise ValueError(f"{name}: not in the acknowledgement table (nodes/ground/acks.py); "
                         "say whether its answer waits for the disk") from None
    return rule == KEPT


async def kept(name: str, keeping: Keeping) -> str:
    """Wait as the table says for ``name``: "" when the change is kept (or need not be), else
    what is missing; ``NotSaved`` when the disk refused it."""
    return await keeping() if waits(name) else ""


def acknowledged(name: str, handler: Handler, keeping: Keeping) -> Handler:
    """``handler`` answered as :data:`ACKS` says for ``name``: a change that was made (its reply
    not a refusal) is answered once :func:`kept`; the reply says what is missing, if anything."""
    if not waits(name):
        return handler

    async def answer(request: dict) -> dict:
        reply = await handler(request)
        if reply.get("accepted", reply.get("success", True)):
            missing = await kept(name, keeping)
            if missing and isinstance(reply.get("message"), str):
                reply["message"] += missing
        return reply

    return answer

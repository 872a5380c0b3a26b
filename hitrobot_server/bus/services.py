"""Services and ROS 2 style actions on the bus.

A provider is either an in-process node or a bridge client; both register an async
handler, so callers never know which one answers.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import uuid
from collections.abc import Awaitable, Callable, Hashable, Iterator
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Protocol

from ..types.registry import ActionType, SrvType
from .topics import Origin

log = logging.getLogger(__name__)

ServiceHandler = Callable[[dict], Awaitable[dict]]

_caller: ContextVar[Origin | None] = ContextVar("service_caller", default=None)
"""Who made the service call being handled: set by :meth:`~.core.Bus.call_service` for the
call's own task only (a context variable), so handlers keep their one-argument signature."""


def service_caller() -> Origin | None:
    """The bridge client whose call is being handled (None: a node, or a call that came from
    another process). A handler uses it to bound what one client may ask for."""
    return _caller.get()


@contextlib.contextmanager
def calling_as(origin: Origin | None) -> Iterator[None]:
    """Run a service handler (and what it awaits) as called by ``origin``."""
    token = _caller.set(origin)
    try:
        yield
    finally:
        _caller.reset(token)


@dataclass(eq=False)
class Service:
    name: str
    stype: SrvType
    owner: Hashable
    node: str
    handler: ServiceHandler
    client: bool = False  # provided by a bridge client, not an in-process node

    @property
    def type_name(self) -> str:
        return self.stype.name


class ServiceRegistry:
    """The services of one bus: one provider per name, and the providers it replaced (a
    client may take over a client's service, as rosbridge lets it; the one it replaced comes
    back when it goes)."""

    def __init__(self) -> None:
        self.current: dict[str, Service] = {}
        self._replaced: dict[str, list[Service]] = {}  # providers replaced, the latest last

    def add(self, service: Service) -> None:
        name = service.name
        current = self.current.get(name)
        if current is not None and current.owner != service.owner:
            self._replaced.setdefault(name, []).append(current)
        self.current[name] = service

    def remove(self, name: str, owner: Hashable) -> bool:
        """Withdraw ``owner``'s provider of ``name``: the current one or a replaced one."""
        service = self.current.get(name)
        stack = self._replaced.get(name, [])
        if service is not None and service.owner == owner:
            if stack:
                self.current[name] = stack.pop()
            else:
                del self.current[name]
        else:
            waiting = [s for s in stack if s.owner == owner]
            if not waiting:
                return False
            stack[:] = [s for s in stack if s.owner != owner]
        if not stack:
            self._replaced.pop(name, None)
        return True

    def names(self) -> list[str]:
        """Every name with a provider, current or replaced."""
        return list(self.current) + list(self._replaced)


# action_msgs/GoalStatus codes
STATUS_UNKNOWN = 0
STATUS_ACCEPTED = 1
STATUS_EXECUTING = 2
STATUS_CANCELING = 3
STATUS_SUCCEEDED = 4
STATUS_CANCELED = 5
STATUS_ABORTED = 6
ACTIVE_STATUSES = frozenset({STATUS_ACCEPTED, STATUS_EXECUTING, STATUS_CANCELING})


@dataclass(eq=False)
class GoalHandle:
    """One goal in flight: the provider reads ``goal``, reports feedback, watches ``cancelled``."""

    action: Action
    goal_id: str
    goal: dict
    on_feedback: Callable[[dict], None] | None = None
    cancelled: asyncio.Event = field(default_factory=asyncio.Event)
    on_cancel: list[Callable[[], None]] = field(default_factory=list)
    uuid: bytes = field(default_factory=lambda: uuid.uuid4().bytes)  # the ROS 2 goal id
    accepted_at: float = 0.0  # bus clock seconds
    status: int = STATUS_EXECUTING
    sent_as: Hashable = None  # the id its sender gave it (a client's op id): any may cancel by it

    def feedback(self, values: dict) -> None:
        if self.on_feedback is not None:
            self.on_feedback(values)
        for watcher in list(self.action.watchers):
            watcher.goal_feedback(self, values)

    def cancel(self) -> None:
        if not self.cancelled.is_set():
            self.cancelled.set()
            if self.status in ACTIVE_STATUSES:
                self.set_status(STATUS_CANCELING)
            for cb in list(self.on_cancel):
                cb()

    def set_status(self, status: int) -> None:
        self.status = status
        for watcher in list(self.action.watchers):
            watcher.goal_status(self)


@dataclass(frozen=True)
class GoalOutcome:
    status: int  # action_msgs/GoalStatus
    values: dict | str  # result message, or an error text
    result: bool  # protocol-level success flag


ActionHandler = Callable[[GoalHandle], Awaitable[GoalOutcome]]


class ActionWatcher(Protocol):
    """Sees every goal of an action, whoever sent it (the ROS 2 hidden interfaces do)."""

    def goal_status(self, handle: GoalHandle) -> None: ...

    def goal_feedback(self, handle: GoalHandle, values: dict) -> None: ...

    def goal_finished(self, handle: GoalHandle, outcome: GoalOutcome) -> None: ...


@dataclass(eq=False)
class Action:
    name: str
    atype: ActionType
    owner: Hashable
    node: str
    handler: ActionHandler
    goals: dict[str, GoalHandle] = field(default_factory=dict)
    client: bool = False  # provided by a bridge client, not an in-process node
    watchers: list[ActionWatcher] = field(default_factory=list)

    @property
    def type_name(self) -> str:
        return self.atype.name

    async def run(self, handle: GoalHandle) -> GoalOutcome:
        """Run one goal to its outcome (never raises); its watchers see it finish."""
        outcome = GoalOutcome(STATUS_ABORTED, f"action '{self.name}' gave no outcome", False)
        try:
            outcome = await self.handler(handle)
        except asyncio.CancelledError:
            outcome = GoalOutcome(STATUS_CANCELED, "goal cancelled", False)
        except Exception as exc:
            log.exception("action %s failed", self.name)
            outcome = GoalOutcome(STATUS_ABORTED, f"action '{self.name}' failed: {exc}", False)
        finally:
            self.goals.pop(handle.goal_id, None)
            handle.status = outcome.status
            for watcher in list(self.watchers):
                watcher.goal_finished(handle, outcome)
        return outcome

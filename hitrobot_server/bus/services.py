"""Services and ROS 2 style actions on the bus.

A provider is either an in-process node or a bridge client; both register an async
handler, so callers never know which one answers.
"""

from __future__ import annotations

import asyncio
import itertools
from collections.abc import Awaitable, Callable, Hashable
from dataclasses import dataclass, field

from ..types.registry import ActionType, SrvType

ServiceHandler = Callable[[dict], Awaitable[dict]]


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


# action_msgs/GoalStatus codes
STATUS_UNKNOWN = 0
STATUS_ACCEPTED = 1
STATUS_EXECUTING = 2
STATUS_CANCELING = 3
STATUS_SUCCEEDED = 4
STATUS_CANCELED = 5
STATUS_ABORTED = 6


@dataclass(eq=False)
class GoalHandle:
    """One goal in flight: the provider reads ``goal``, reports feedback, watches ``cancelled``."""

    action: Action
    goal_id: str
    goal: dict
    on_feedback: Callable[[dict], None] | None = None
    cancelled: asyncio.Event = field(default_factory=asyncio.Event)
    on_cancel: list[Callable[[], None]] = field(default_factory=list)

    def feedback(self, values: dict) -> None:
        if self.on_feedback is not None:
            self.on_feedback(values)

    def cancel(self) -> None:
        if not self.cancelled.is_set():
            self.cancelled.set()
            for cb in list(self.on_cancel):
                cb()


@dataclass(frozen=True)
class GoalOutcome:
    status: int  # action_msgs/GoalStatus
    values: dict | str  # result message, or an error text
    result: bool  # protocol-level success flag


ActionHandler = Callable[[GoalHandle], Awaitable[GoalOutcome]]

_goal_ids = itertools.count(1)


@dataclass(eq=False)
class Action:
    name: str
    atype: ActionType
    owner: Hashable
    node: str
    handler: ActionHandler
    goals: dict[str, GoalHandle] = field(default_factory=dict)
    client: bool = False  # provided by a bridge client, not an in-process node

    @property
    def type_name(self) -> str:
        return self.atype.name

    def new_goal_id(self) -> str:
        return f"goal:{self.name}:{next(_goal_ids)}"

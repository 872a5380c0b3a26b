"""The actions of one bus: one provider per name, each with the ROS 2 hidden interfaces while it
is advertised (:mod:`.action_interfaces`), and the goals handed to them."""

from __future__ import annotations

import asyncio
import itertools
from collections.abc import Callable, Hashable

from .action_interfaces import ActionBus, ActionInterfaces
from .services import STATUS_EXECUTING, Action, GoalHandle, GoalOutcome


class ActionRegistry:
    def __init__(self, bus: ActionBus) -> None:
        self.bus = bus
        self.current: dict[str, Action] = {}  # name -> provider
        self._interfaces: dict[str, ActionInterfaces] = {}
        self._goal_ids = itertools.count(1)  # numbers every goal started on the bus

    def add(self, action: Action) -> None:
        """Register ``action``; the provider it replaces loses its goals (cancelled)."""
        old = self.current.get(action.name)
        if old is not None:
            self._drop_interfaces(action.name)
            for goal in list(old.goals.values()):
                goal.cancel()
        self.current[action.name] = action
        self._interfaces[action.name] = ActionInterfaces(self.bus, action)

    def remove(self, name: str, owner: Hashable) -> bool:
        """Withdraw ``owner``'s provider of ``name``, cancelling its goals."""
        action = self.current.get(name)
        if action is None or action.owner != owner:
            return False
        del self.current[name]
        for goal in list(action.goals.values()):
            goal.cancel()
        self._drop_interfaces(name)
        return True

    def _drop_interfaces(self, name: str) -> None:
        interfaces = self._interfaces.pop(name, None)
        if interfaces is not None:
            interfaces.close()

    def start(
        self,
        action: Action,
        goal: dict,
        on_feedback: Callable[[dict], None] | None,
        goal_uuid: bytes | None,
        accepted_at: float,
    ) -> tuple[GoalHandle, asyncio.Task[GoalOutcome]]:
        """Hand a goal to ``action`` (local or a proxy); the task resolves to its outcome."""
        handle = GoalHandle(action, f"goal:{action.name}:{next(self._goal_ids)}", goal,
                            on_feedback, accepted_at=accepted_at)
        if goal_uuid is not None:
            handle.uuid = goal_uuid
        action.goals[handle.goal_id] = handle
        handle.set_status(STATUS_EXECUTING)
        return handle, asyncio.ensure_future(action.run(handle))

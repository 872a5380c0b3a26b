"""What the fleet node offers the parts it is made of (dispatch, schedules): a protocol, so
they need not import the node that imports them."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Protocol

from ...bus.core import Bus
from .board import Board
from .policy import ChargePolicy
from .runner import TaskRunner
from .tasks import Task
from .traffic import Traffic


class Site(Protocol):
    bus: Bus
    board: Board
    policy: ChargePolicy
    runner: TaskRunner
    clock: Callable[[], float]
    members: dict[str, tuple[float, dict]]
    site_map: dict | None
    traffic: Traffic

    def robots(self) -> list[dict]: ...
    def free(self) -> list[dict]: ...
    def start_task(self, task: Task, robot: str) -> None: ...
    def kick(self) -> None: ...
    def changed(self) -> None: ...
    def publish_tasks(self) -> None: ...
    def service(self, name: str, type_name: str,
                handler: Callable[[dict], Awaitable[dict]]) -> None: ...

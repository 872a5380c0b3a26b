"""Base for in-process nodes: they use the bus exactly as a bridge client does."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
from collections.abc import Awaitable, Callable, Coroutine
from typing import Any, ClassVar

from ..bus.core import Bus
from ..bus.demand import Passive
from ..bus.services import ActionHandler, ServiceHandler
from ..bus.topics import Message, RequestRejected
from ..robot.backend import BackendError, Link, NotConnectedError
from .ground.pacing import Pace, repeat

log = logging.getLogger(__name__)


def require_finite(path: str, *values: float) -> None:
    """Refuse a request carrying NaN or an infinity, naming the offending field."""
    if not all(math.isfinite(v) for v in values):
        raise RequestRejected(f"field '{path}' must be a finite number")


def _log_scope(module: str) -> str:
    """The modules whose log records a node's name goes with: its module, or for a node in a
    package of its own (``nodes/map_manager/``) every module of that package."""
    package = __name__.rpartition(".")[0] + "."
    if module.startswith(package):
        return package + module.removeprefix(package).split(".")[0]
    return module


class Node:
    """A named participant; its registrations are undone by ``close``."""

    GLOBAL_NAMES: ClassVar[tuple[str, ...]] = ()
    """The global names the node serves or takes requests on (its node name, topics,
    services, actions, parameters): no robot may be named like their first segment, or its
    ``/NAME/...`` would shadow them. The assembly collects them (``reserved_names``)."""

    def __init__(self, bus: Bus, name: str):
        self.bus = bus
        self.name = name = bus.node_name(name)
        self._subs: list[tuple[str, object]] = []
        bus.register_node(name)
        if type(self).__module__ != __name__:  # its module's records name it on /rosout
            bus.log_names[_log_scope(type(self).__module__)] = name

    def advertise(self, topic: str, type_name: str, latch: bool = False) -> None:
        self.bus.advertise(topic, type_name, self, self.name, latch=latch)

    def publish(self, topic: str, msg: dict) -> Message:
        return self.bus.publish(topic, msg)

    def subscribe(self, topic: str, type_name: str, callback: Callable[[Message], None], *,
                  passive: bool = False) -> None:
        """``callback`` gets the Message: ``.msg`` is the data; raising RequestRejected sends
        the publishing client a status error, and ``.reply`` answers it later. ``passive``:
        listen, asking for nothing to be fetched (bus/demand.py)."""
        key = Passive((self, topic)) if passive else (self, topic)
        self.bus.subscribe(topic, type_name, key, self.name, callback)
        self._subs.append((topic, key))

    def service(self, name: str, type_name: str, handler: ServiceHandler) -> None:
        self.bus.advertise_service(name, type_name, self, self.name, handler)

    def action(self, name: str, type_name: str, handler: ActionHandler) -> None:
        self.bus.advertise_action(name, type_name, self, self.name, handler)

    def close(self) -> None:
        self.bus.remove_owner(self, [key for _topic, key in self._subs])
        self.bus.unregister_node(self.name)

    # The hooks the assembly and the state binder call on every node (defaults: nothing).
    async def start(self) -> None:
        """Start the node's workers, once every node of its server is made."""

    async def stop(self) -> None:
        """Undo the node's registrations (a node with workers stops them first)."""
        self.close()

    def adopt(self, restore: bool) -> None:
        """A state folder was bound after the start (a REST robot said who it is): take its
        sections (``restore``) or write the node's own into it (they are newer)."""

    def restored(self) -> list[str]:
        """What the node took back from the state folder, as phrases for the start-up log."""
        return []


class RobotNode(Node):
    """A node backed by the robot: owns background tasks, stopped by :meth:`stop`."""

    def __init__(self, bus: Bus, name: str, link: Link | None):
        super().__init__(bus, name)
        self.link = link
        self._tasks: set[asyncio.Task] = set()

    @property
    def robot_connected(self) -> bool:
        return self.link is not None and self.link.connected

    def spawn(self, coro: Coroutine[Any, Any, Any]) -> asyncio.Task:
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    def every(self, period: float, work: Callable[[], Awaitable[None]],
              needs_robot: bool = True, *, pace: Pace | None = None) -> asyncio.Task:
        """Run ``work`` at a fixed rate without drift; ticks are skipped while the robot is
        offline (when ``needs_robot``) and a slow tick never causes a burst. With ``pace``
        the rate follows who reads its topics (ground/pacing.py)."""
        task = self.spawn(repeat(period, lambda: _work_once(work, self.name), pace,
                                 lambda: not needs_robot or self.robot_connected))
        if pace is not None:
            task.add_done_callback(lambda _t: pace.unwatch())
        return task

    async def stop(self) -> None:
        for task in list(self._tasks):
            task.cancel()
        for task in list(self._tasks):
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self.close()


async def _work_once(work: Callable[[], Awaitable[None]], name: str) -> None:
    """One tick of a node's worker: a robot away is no news, its errors are logged as the
    node's (its name on /rosout)."""
    try:
        await work()
    except NotConnectedError:
        pass
    except BackendError as exc:
        log.warning("%s: %s", name, exc, extra={"ros_node": name})
    except Exception:
        log.exception("%s: worker failed", name, extra={"ros_node": name})

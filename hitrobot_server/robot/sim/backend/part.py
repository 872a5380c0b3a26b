"""What every adapter of the simulated robot shares: the runner it answers from, and the one
way a request is carried out (refused while the simulator is stopped, its ``ValueError`` a
:class:`BackendError`, a change answered once it is on disk)."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import TypeVar

from ...backend import BackendError, NotConnectedError, UnsupportedError
from ...model import MapKind
from ..runner import SimRunner
from ..simulator import Simulator

T = TypeVar("T")


class SimPart:
    """One capability of a simulated robot over its :class:`SimRunner`. Every request is
    answered synchronously from the simulator's state, so awaiting it never waits on the
    stepping task."""

    def __init__(self, runner: SimRunner) -> None:
        self.runner = runner

    @property
    def simulator(self) -> Simulator:
        """The simulator now running (a reboot replaces it)."""
        return self.runner.simulator

    def _alive(self) -> None:
        if not self.runner.running:
            raise NotConnectedError("simulator is not running")

    def _call(self, fn: Callable[..., T], *args: object) -> T:
        """Run a simulator call as a backend request: refuse when stopped, translate errors."""
        self._alive()
        try:
            return fn(*args)
        except ValueError as exc:
            raise BackendError(str(exc)) from exc

    async def _change(self, fn: Callable[..., T], *args: object) -> T:
        """A request that changes what the robot remembers: answered once it is on disk."""
        memory = self.runner.memory
        lines = None if memory is None else self.simulator.map.saved_lines()
        result = self._call(fn, *args)
        if memory is not None:
            pending = memory.sync(self.simulator, asyncio.get_running_loop().time(),
                                  urgent=True)
            if pending is not None:
                try:
                    await pending
                except OSError as exc:
                    undone = memory.take_back_lines(self.simulator, lines)
                    raise BackendError(f"{exc}" + ("; the walls, tracks and home were taken "
                                                   "back" if undone else "")) from None
        return result


def explore_only(kind: MapKind) -> None:
    if kind != MapKind.EXPLORERMAP:
        raise UnsupportedError(f"the simulator only has an explore map, not {kind!r}")

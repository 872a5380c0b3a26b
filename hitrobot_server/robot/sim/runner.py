"""``SimRunner``: a :class:`Simulator` stepped on the event loop, its memory kept, rebooted,
and the requests of the backend's adapters (:class:`RunnerPart`) answered from it.

A background task steps the simulator at a fixed rate, paced against the event loop's clock
(``time_scale`` > 1 runs faster than real time). Work inside one step is bounded (planning and
relocalization run in slices), typically a few milliseconds; the slowest step seen is kept in
:attr:`SimRunner.max_step_seconds` for diagnostics. While it runs the robot is connected.
Every request is answered synchronously from the simulator's state (:meth:`SimRunner.call`,
:meth:`SimRunner.change`), so awaiting one never waits on the stepping task.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from collections.abc import Callable
from typing import TypeVar

from ..backend import BackendError, NotConnectedError
from .persist import SimMemory
from .simulator import Simulator

log = logging.getLogger(__name__)
T = TypeVar("T")

SLOW_STEP = 0.05
"""A step slower than this (s) is logged: it delays every other task on the loop."""
MAX_CATCH_UP = 5
"""Steps run back to back at most when the loop fell behind; older backlog is dropped."""
SAMPLE_EVERY = 0.25
"""Wall-clock seconds between samples of the pose, battery and map for the state store."""


class SimRunner:
    """Runs (or pauses) one simulated robot; a reboot replaces its :attr:`simulator`."""

    def __init__(self, simulator: Simulator, rate_hz: float, time_scale: float,
                 memory: SimMemory | None) -> None:
        self.simulator = simulator
        self.memory = memory
        self._sampled = -math.inf
        self._period = 1.0 / rate_hz
        self._time_scale = time_scale
        self._task: asyncio.Task[None] | None = None
        self._reboot: asyncio.Task[None] | None = None
        self.max_step_seconds = 0.0
        self.reboot_delay = 2.0
        """Wall-clock seconds a simulated reboot keeps the robot offline."""

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    async def start(self) -> None:
        if not self.running:
            self._task = asyncio.get_running_loop().create_task(self._run(), name="sim-stepper")

    async def stop(self) -> None:
        reboot, self._reboot = self._reboot, None
        if reboot is not None and reboot is not asyncio.current_task():
            reboot.cancel()
        task, self._task = self._task, None
        if task is not None:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
            if self.memory is not None:  # the last pose and map (the store flushes on close)
                self.memory.sync(self.simulator, asyncio.get_running_loop().time(), urgent=True)

    async def power_off(self) -> None:
        """The simulated robot goes offline and stays so (until the server restarts)."""
        self.alive()
        await self.stop()

    async def reboot(self) -> None:
        """Offline now; back after :attr:`reboot_delay` as a freshly started simulator (same
        world, seed and configuration, no actions) with what the robot keeps: its map, lines,
        home and pose from the state folder (as at start-up when there is none)."""
        self.alive()
        await self.stop()

        async def come_back() -> None:
            await asyncio.sleep(self.reboot_delay)
            self.simulator = self.simulator.restarted()
            if self.memory is not None:  # a robot keeps its map, lines and pose on reboot
                self.memory.restore(self.simulator)
            self._reboot = None
            await self.start()

        self._reboot = asyncio.get_running_loop().create_task(come_back(), name="sim-reboot")

    def alive(self) -> None:
        """Refuse a request while the simulator is not running."""
        if not self.running:
            raise NotConnectedError("simulator is not running")

    def call(self, fn: Callable[..., T], *args: object) -> T:
        """Run a simulator call as a backend request: refuse when stopped, translate errors."""
        self.alive()
        try:
            return fn(*args)
        except ValueError as exc:
            raise BackendError(str(exc)) from exc

    async def change(self, fn: Callable[..., T], *args: object) -> T:
        """A request that changes what the robot remembers: answered once it is on disk (the
        walls, tracks and home taken back when the write fails)."""
        memory = self.memory
        lines = None if memory is None else self.simulator.map.saved_lines()
        result = self.call(fn, *args)
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

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        due = loop.time()
        while True:
            behind = 0
            while loop.time() >= due and behind < MAX_CATCH_UP:
                try:
                    self._step()
                except Exception:
                    log.exception("simulator step failed; the simulated robot is now offline")
                    raise
                due += self._period
                behind += 1
            now = loop.time()
            if self.memory is not None and now - self._sampled >= SAMPLE_EVERY:
                self._sampled = now
                self.memory.sync(self.simulator, now)
            if now >= due:
                due = now + self._period
            await asyncio.sleep(due - now if due > now else 0.0)

    def _step(self) -> None:
        started = time.perf_counter()
        self.simulator.step(self._period * self._time_scale)
        spent = time.perf_counter() - started
        if spent > self.max_step_seconds:
            self.max_step_seconds = spent
        if spent > SLOW_STEP:
            log.warning("simulator step took %.1f ms", spent * 1000.0)


class RunnerPart:
    """One capability of a simulated robot (an adapter of :mod:`.backend`) over its runner."""

    def __init__(self, runner: SimRunner) -> None:
        self.runner = runner

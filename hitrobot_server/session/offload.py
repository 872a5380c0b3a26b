"""Big ops run in a worker process so that no client waits on another's map.

Parsing a 10 MB publish, or encoding it as JSON or png, takes 100-500 ms of C code that holds
the GIL (see rosbridge/frames.py); on the event loop that is 100-500 ms in which no other client
gets an answer. Ops and messages of at least ``OFFLOAD_BYTES`` go to a small process pool
instead; smaller ones stay inline, where a pool round trip (~1 ms) would cost more than the work.
The pool starts on first use, so a server that never sees a big message never pays for it; the
server owns it and shuts it down when it stops. A server whose robot publishes a big map warms
it as it starts (:meth:`WorkerPool.warm`, not waited for): spawning a process and importing
the encoders takes 0.3-2 s, which the first subscriber to ``/map`` would otherwise wait on top
of the encoding. While it warms, big ops are built on the loop as small ones are: none waits
for a spawn (the loop is held for one encoding, as a server without a pool would be).

A pool left idle for ``IDLE_STOP`` seconds is shut down (it starts again on the next big
message, or at once when it was warmed: fresh processes, small again): what a burst of big
messages left in its processes (a parse's peak, the allocator's fragments) is given back
rather than kept for the server's whole life.

The pool's processes die with the server however it ends (kill -9 too): each asks Linux for
SIGKILL when its parent dies (``PR_SET_PDEATHSIG``). Without that an idle pool process waits
for work forever, and keeps multiprocessing's resource tracker (whose pipe it holds) alive too;
with it the tracker sees its pipe close and exits by itself.
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import importlib
import logging
import multiprocessing
import os
import signal
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

T = TypeVar("T")
log = logging.getLogger(__name__)

WORKERS = max(1, min(2, (os.cpu_count() or 2) - 1))
"""One worker on 2 cores (the loop keeps a core; two measured no better there), two above."""

WORKER_NICENESS = 10
"""Workers run at a lower priority than the event loop: on a busy 2-core machine the loop
(every client's answers) gets the CPU first, the big message's encoding what is left."""


IDLE_STOP = 300.0
"""Seconds without a task after which the pool's processes are stopped (memory given back)."""

PR_SET_PDEATHSIG = 1  # linux/prctl.h


def die_with_parent(parent: int) -> None:
    """Ask Linux to SIGKILL this process when its parent dies (``prctl(PR_SET_PDEATHSIG)``);
    if ``parent`` is already gone (it died before the call), exit now. Elsewhere: nothing."""
    if not sys.platform.startswith("linux"):
        return
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:
        os._exit(0)


def _start_worker(parent: int) -> None:
    """Each pool process, as it starts: dies with the server, runs below the event loop."""
    die_with_parent(parent)
    with contextlib.suppress(OSError, AttributeError):  # not everywhere allowed or available
        os.nice(WORKER_NICENESS)


def _warm(modules: tuple[str, ...]) -> int:
    """A pool process's first task: import what the big ops will run (its pid back)."""
    for name in modules:
        importlib.import_module(name)
    return os.getpid()


class WorkerPool:
    """The worker processes of one server (made at the top, shut down when it stops)."""

    def __init__(self, workers: int = WORKERS, idle_stop: float = IDLE_STOP):
        self.workers = workers
        self.idle_stop = idle_stop
        self._pool: ProcessPoolExecutor | None = None
        self._running = 0  # tasks in the pool now
        self._idle: asyncio.TimerHandle | None = None  # stops an idle pool
        self._preload: tuple[str, ...] | None = None  # warmed with these: kept warm
        self._warming: asyncio.Future | None = None  # the processes' first tasks

    def _executor(self) -> ProcessPoolExecutor:
        if self._pool is None:
            # spawn, not fork: the server has threads (asyncio.to_thread) whose locks a fork
            # copies
            self._pool = ProcessPoolExecutor(
                self.workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_start_worker, initargs=(os.getpid(),),
            )
        return self._pool

    async def run(self, fn: Callable[..., T], *args: Any) -> T:
        """``fn(*args)`` in the worker pool (here, while it warms); a crashed pool is replaced
        for the next call."""
        if self._warming is not None and not self._warming.done():
            return fn(*args)
        pool = self._executor()
        loop = asyncio.get_running_loop()
        if self._idle is not None:
            self._idle.cancel()
            self._idle = None
        self._running += 1
        try:
            return await loop.run_in_executor(pool, fn, *args)
        except BrokenProcessPool:
            if self._pool is pool:
                self._pool = None
            raise
        finally:
            self._running -= 1
            if not self._running and self._pool is pool and self.idle_stop > 0:
                self._idle = loop.call_later(self.idle_stop, self._idle_stop)

    def warm(self, *modules: str) -> None:
        """Spawn every process now, each importing ``modules``, and keep the pool warm: an
        idle stop starts fresh processes at once. :meth:`warmed` waits for them."""
        self._preload = modules
        pool = self._executor()
        t0 = time.perf_counter()
        self._warming = warming = asyncio.gather(*(
            asyncio.wrap_future(pool.submit(_warm, modules)) for _ in range(self.workers)))

        def done(_: asyncio.Future) -> None:  # a failure is read here and logged
            if warming.cancelled():  # shut down before it was warm
                return
            exc = warming.exception()
            if exc is None:
                log.info("worker pool warm: %d process(es) in %.0f ms", len(warming.result()),
                         (time.perf_counter() - t0) * 1000)
            elif not isinstance(exc, asyncio.CancelledError):
                log.warning("the worker pool did not warm up: %r", exc)

        warming.add_done_callback(done)

    async def warmed(self, timeout: float) -> list[int]:
        """The pids of the warmed processes once each has run its first task ([] if the
        pool was not warmed, or it broke or took longer than ``timeout``)."""
        warming = self._warming
        if warming is None:
            return []
        try:
            return await asyncio.wait_for(asyncio.shield(warming), timeout)
        except (TimeoutError, BrokenProcessPool, OSError):
            return []
        except asyncio.CancelledError:
            if warming.cancelled():  # the pool was shut down meanwhile
                return []
            raise  # the caller's own cancellation

    @property
    def started(self) -> bool:
        """Whether its processes exist now (spawned, or spawning)."""
        return self._pool is not None

    def _idle_stop(self) -> None:
        preload = self._preload
        self.shutdown()
        if preload is not None:
            self.warm(*preload)

    def shutdown(self) -> None:
        """Stop the workers (they start again on the next :meth:`run`)."""
        pool, self._pool = self._pool, None
        self._preload = None
        if self._warming is not None:
            self._warming.cancel()
            self._warming = None
        if self._idle is not None:
            self._idle.cancel()
            self._idle = None
        if pool is not None:
            pool.shutdown(wait=False, cancel_futures=True)

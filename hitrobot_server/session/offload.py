"""Big ops run in a worker process so that no client waits on another's map.

Parsing a 10 MB publish, or encoding it as JSON or png, takes 100-500 ms of C code that holds
the GIL (see rosbridge/frames.py); on the event loop that is 100-500 ms in which no other client
gets an answer. Ops and messages of at least ``OFFLOAD_BYTES`` go to a small process pool
instead; smaller ones stay inline, where a pool round trip (~1 ms) would cost more than the work.
The pool starts on first use, so a server that never sees a big message never pays for it; the
server owns it and shuts it down when it stops.

A pool left idle for ``IDLE_STOP`` seconds is shut down (it starts again on the next big
message): what a burst of big messages left in its processes (a parse's peak, the allocator's
fragments) is given back rather than kept for the server's whole life.

The pool's processes die with the server however it ends (kill -9 too): each asks Linux for
SIGKILL when its parent dies (``PR_SET_PDEATHSIG``). Without that an idle pool process waits
for work forever, and keeps multiprocessing's resource tracker (whose pipe it holds) alive too;
with it the tracker sees its pipe close and exits by itself.
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

T = TypeVar("T")

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


class WorkerPool:
    """The worker processes of one server (made at the top, shut down when it stops)."""

    def __init__(self, workers: int = WORKERS, idle_stop: float = IDLE_STOP):
        self.workers = workers
        self.idle_stop = idle_stop
        self._pool: ProcessPoolExecutor | None = None
        self._running = 0  # tasks in the pool now
        self._idle: asyncio.TimerHandle | None = None  # stops an idle pool

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
        """``fn(*args)`` in the worker pool; a crashed pool is replaced for the next call."""
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
                self._idle = loop.call_later(self.idle_stop, self.shutdown)

    def shutdown(self) -> None:
        """Stop the workers (they start again on the next :meth:`run`)."""
        pool, self._pool = self._pool, None
        if self._idle is not None:
            self._idle.cancel()
            self._idle = None
        if pool is not None:
            pool.shutdown(wait=False, cancel_futures=True)

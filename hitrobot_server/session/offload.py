"""Big ops run in a worker process so that no client waits on another's map.

Parsing a 10 MB publish, or encoding it as JSON or png, takes 100-500 ms of C code that holds
the GIL (see protocol/bulk.py); on the event loop that is 100-500 ms in which no other client
gets an answer. Ops and messages of at least ``bulk.OFFLOAD_BYTES`` go to a small process pool
instead; smaller ones stay inline, where a pool round trip (~1 ms) would cost more than the work.
The pool starts on first use, so a server that never sees a big message never pays for it.
"""

from __future__ import annotations

import asyncio
import contextlib
import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

T = TypeVar("T")

WORKERS = max(1, min(2, (os.cpu_count() or 2) - 1))
"""One worker on 2 cores (the loop keeps a core; two measured no better there), two above."""

_pool: ProcessPoolExecutor | None = None


WORKER_NICENESS = 10
"""Workers run at a lower priority than the event loop: on a busy 2-core machine the loop
(every client's answers) gets the CPU first, the big message's encoding what is left."""


def _lower_priority() -> None:
    with contextlib.suppress(OSError, AttributeError):  # not everywhere allowed or available
        os.nice(WORKER_NICENESS)


def _executor() -> ProcessPoolExecutor:
    global _pool
    if _pool is None:
        # spawn, not fork: the server has threads (asyncio.to_thread) whose locks a fork copies
        _pool = ProcessPoolExecutor(
            WORKERS, mp_context=multiprocessing.get_context("spawn"), initializer=_lower_priority
        )
    return _pool


async def run(fn: Callable[..., T], *args: Any) -> T:
    """``fn(*args)`` in the worker pool; a crashed pool is replaced for the next call."""
    global _pool
    pool = _executor()
    try:
        return await asyncio.get_running_loop().run_in_executor(pool, fn, *args)
    except BrokenProcessPool:
        if _pool is pool:
            _pool = None
        raise

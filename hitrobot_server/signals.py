"""Waiting for Ctrl-C or a service manager's SIGTERM, for every long-running command."""

from __future__ import annotations

import asyncio
import contextlib
import signal


async def until_terminated() -> None:
    """Return when SIGINT or SIGTERM arrives, so the caller can shut down cleanly."""
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError):  # platforms without signal handlers
            loop.add_signal_handler(sig, stop.set)
    await stop.wait()

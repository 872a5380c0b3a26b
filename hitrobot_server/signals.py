"""Waiting for Ctrl-C or a service manager's SIGTERM, for every long-running command, and
telling systemd how the service is doing (``sd_notify``: ready, alive, stopping).

systemd's notify protocol is one datagram of ``KEY=VALUE`` lines to the unix socket named by
``$NOTIFY_SOCKET`` (``@`` first: Linux's abstract namespace); without that variable nothing is
sent. ``$WATCHDOG_USEC`` (with ``$WATCHDOG_PID``, when it names us) asks for ``WATCHDOG=1`` at
least that often: it is sent from the event loop, so a loop that stops answering stops it and
systemd restarts the service.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import shutil
import signal
import socket
import sys
from collections.abc import Mapping

# The event SIGINT/SIGTERM set, and the event loop whose handlers set it.
_terminated: tuple[asyncio.Event, asyncio.AbstractEventLoop] | None = None


def catch_termination() -> None:
    """From now on SIGINT and SIGTERM are caught for :func:`until_terminated`, never the default
    kill: a command calls this as its event loop starts, before it prints its banner or tells
    systemd it is ready, so a signal sent the moment that line is read (a script, a test,
    systemd) still stops it cleanly; one that comes while it starts stops it once started."""
    global _terminated
    stop, loop = asyncio.Event(), asyncio.get_running_loop()
    _terminated = (stop, loop)
    for sig in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError):  # platforms without signal handlers
            loop.add_signal_handler(sig, stop.set)


async def until_terminated() -> None:
    """Return when SIGINT or SIGTERM arrives (or has arrived since :func:`catch_termination`),
    so the caller can shut down cleanly."""
    if _terminated is None or _terminated[1] is not asyncio.get_running_loop():
        catch_termination()
    await _terminated[0].wait()


class ServiceNotifier:
    """``sd_notify`` for the process systemd started (a no-op without ``$NOTIFY_SOCKET``)."""

    def __init__(self, environ: Mapping[str, str] | None = None):
        env = os.environ if environ is None else environ
        name = env.get("NOTIFY_SOCKET", "")
        self.address = "\0" + name[1:] if name.startswith("@") else name
        usec = env.get("WATCHDOG_USEC", "")
        pid = env.get("WATCHDOG_PID", "")
        ours = not pid or pid == str(os.getpid())
        self.watchdog = int(usec) / 1e6 if usec.isdigit() and int(usec) > 0 and ours else 0.0

    def notify(self, *states: str) -> bool:
        """Send ``states`` (``READY=1``...); False when there is nobody to tell or it failed."""
        if not self.address:
            return False
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC) as sock:
            try:
                sock.sendto("\n".join(states).encode(), self.address)
            except OSError:
                return False
        return True

    async def keep_alive(self) -> None:
        """``WATCHDOG=1`` at half the asked period, for as long as the event loop runs it."""
        if not self.watchdog or not self.address:
            return
        while True:
            self.notify("WATCHDOG=1")
            await asyncio.sleep(self.watchdog / 2)


async def serve_until_terminated(status: str = "") -> None:
    """Tell systemd the service is ready, keep its watchdog fed, and return when SIGINT or
    SIGTERM arrives, after telling it the service is stopping."""
    notifier = ServiceNotifier()
    notifier.notify("READY=1", *([f"STATUS={status}"] if status else []))
    alive = asyncio.ensure_future(notifier.keep_alive())
    try:
        await until_terminated()
    finally:
        alive.cancel()
        notifier.notify("STOPPING=1")


PARENT_DIR = "HITROBOT_PARENT_DIR"
"""The environment variable a server sets for a process it starts with stdin a pipe from
itself (a ``--workers`` worker, the console's replay): the parent's temporary folder, which
the child removes if the parent dies without doing it (``kill -9``)."""


async def until_stdin_closed() -> None:
    """Return when stdin reaches its end: the stdin of a process a server started is a pipe
    from it, which ends when the parent does (whatever killed it)."""
    closed = asyncio.Event()

    class Watch(asyncio.Protocol):
        def connection_lost(self, exc: Exception | None) -> None:
            closed.set()

    transport, _ = await asyncio.get_running_loop().connect_read_pipe(Watch, sys.stdin)
    try:
        await closed.wait()
    finally:
        transport.close()


def started_by_a_server() -> bool:
    """Whether a server started this process and will hear of its end (:data:`PARENT_DIR`)."""
    return bool(os.environ.get(PARENT_DIR))


def remove_parent_dir() -> None:
    """The parent died without removing its temporary folder: remove it for it."""
    folder = os.environ.get(PARENT_DIR)
    if folder:
        shutil.rmtree(folder, ignore_errors=True)

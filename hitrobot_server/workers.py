"""``--workers N``: N server processes behind the same WebSocket and TCP ports.

The parent reserves the ports (a bound, never listening SO_REUSEPORT socket each, so ``0``
becomes one fixed port and nobody else takes it), then starts the workers one after another:
``python -m hitrobot_server <the same flags> --worker-id I``. Each worker listens on the shared
ports with SO_REUSEPORT, so the kernel spreads new connections over them, and joins the others
over the Zenoh link (``--bus zenoh``) on Unix sockets in a private folder: each listens on its
own socket and connects to those of the workers already running, so a restarted worker joins
the rest by itself. Worker 0 runs the robot and every node, and keeps the parameters (their
rosapi services cross the link); the others run the bridge and their own rosapi.

A worker that exits on its own is started again (after a pause that grows while it keeps
failing at once); Ctrl-C or SIGTERM to the parent stops them all. Each worker's stdin is a pipe
from the parent: when the parent is gone (even killed), the workers stop too.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from . import __version__
from .bus.zenoh.keys import endpoints
from .config import Settings
from .signals import PARENT_DIR, serve_until_terminated

log = logging.getLogger(__name__)

START_TIMEOUT = 60.0  # seconds a worker has to print its address
STOP_TIMEOUT = 10.0  # seconds a worker has to stop after SIGTERM before it is killed
QUICK_EXIT = 10.0  # a worker that dies sooner than this after starting is failing at once
MAX_QUICK_EXITS = 5  # ... this many times in a row: give up and stop everything
RESTART_PAUSE = (0.2, 5.0)  # the first pause before a restart, and the longest
METRICS_DIR = "HITROBOT_METRICS_DIR"  # where the workers share their /metrics (metrics.py)
SYSTEMD_VARIABLES = ("NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID")  # the parent's own


def check_zenoh() -> None:
    """``--workers`` > 1 joins the workers over Zenoh: say so clearly when it is missing."""
    try:
        import zenoh  # noqa: F401  (the workers import it; the parent only checks)
    except ImportError:
        raise ValueError(
            "--workers above 1 joins the workers over Zenoh and needs the eclipse-zenoh "
            "package; install it with: pip install 'hitrobot-server[zenoh]'"
        ) from None


def reserve_port(address: str, port: int) -> socket.socket:
    """A bound SO_REUSEPORT socket that never listens: it holds ``port`` (0 = a free one) for
    the workers, which bind it too, and receives no connection itself."""
    family, kind, proto, _name, addr = socket.getaddrinfo(
        address or None, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE
    )[0]
    sock = socket.socket(family, kind, proto)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
    try:
        sock.bind(addr)
    except OSError:
        sock.close()
        raise
    return sock


def without_workers_flag(argv: list[str]) -> list[str]:
    """The command line minus ``--workers N`` (the parent's own flag)."""
    out: list[str] = []
    skip = False
    for arg in argv:
        if skip:
            skip = False
        elif arg == "--workers":
            skip = True
        elif not arg.startswith("--workers="):
            out.append(arg)
    return out


@dataclass
class Worker:
    """One worker slot: its current process and how often it died right after starting."""

    index: int
    generation: int = 0
    proc: WorkerProcess | None = None
    started: float = 0.0
    quick_exits: int = 0
    socket_path: str = ""


class Supervisor:
    """Starts, watches and stops the workers of one ``--workers`` server."""

    def __init__(self, settings: Settings, argv: list[str]):
        self.settings = settings
        self.count = settings.process.worker_count
        self.argv = without_workers_flag(argv)
        self.workers = [Worker(i) for i in range(self.count)]
        self.stopping = False
        self.failed: str | None = None
        self.port = 0
        self.tcp_port = 0
        self._reserved: list[socket.socket] = []
        self._dir = ""
        self._watchers: set[asyncio.Task] = set()
        self._gave_up = asyncio.Event()

    async def start(self) -> None:
        s = self.settings.transport
        ws = reserve_port(s.address, s.port)
        self._reserved.append(ws)
        self.port = ws.getsockname()[1]
        if s.tcp_port:
            tcp = reserve_port(s.address, s.tcp_port if s.tcp_port > 0 else 0)
            self._reserved.append(tcp)
            self.tcp_port = tcp.getsockname()[1]
        self._dir = tempfile.mkdtemp(prefix="hitrobot-workers-")
        for worker in self.workers:  # one by one: each connects to those already listening
            await self._spawn(worker)

    def _command(self, worker: Worker) -> list[str]:
        s = self.settings.bus
        worker.generation += 1
        worker.socket_path = str(Path(self._dir) / f"w{worker.index}-{worker.generation}.sock")
        listen = [f"unixsock-stream/{worker.socket_path}"]
        if worker.index == 0:
            listen += endpoints(s.zenoh_listen)  # other servers join the robot's worker
        peers = [
            f"unixsock-stream/{w.socket_path}" for w in self.workers
            if w is not worker and w.proc is not None and w.proc.returncode is None
        ]
        args = [
            sys.executable, "-m", "hitrobot_server", *self.argv,
            "--workers", "1", "--worker-id", str(worker.index),
            "--port", str(self.port), "--tcp-port", str(self.tcp_port),
            "--bus", "zenoh", "--zenoh-listen", ",".join(listen),
        ]
        connect = peers + endpoints(s.zenoh_connect)
        if connect:
            args += ["--zenoh-connect", ",".join(connect)]
        return args  # only worker 0 starts the robots (StartPlan.primary)

    async def _spawn(self, worker: Worker) -> None:
        proc = await start_worker(self._command(worker), {METRICS_DIR: self._dir,
                                                          PARENT_DIR: self._dir})
        worker.proc = proc
        worker.started = time.monotonic()
        try:
            line = await asyncio.wait_for(self._ready_line(proc), START_TIMEOUT)
        except TimeoutError:
            line = ""
        if not line:
            await _terminate(proc)
            raise OSError(f"worker {worker.index} did not start (exit code {proc.returncode})")
        log.info("worker %d (pid %d) is serving", worker.index, proc.pid)
        task = asyncio.create_task(self._watch(worker, proc))
        self._watchers.add(task)
        task.add_done_callback(self._watchers.discard)

    @staticmethod
    async def _ready_line(proc: WorkerProcess) -> str:
        """The worker's first line on stdout is its address: it is serving."""
        assert proc.stdout is not None
        while raw := await proc.stdout.readline():
            line = raw.decode(errors="replace")
            if "://" in line:
                return line
        return ""

    async def _watch(self, worker: Worker, proc: WorkerProcess) -> None:
        """Wait for the worker to exit; unless stopping, start it again (bounded). Its exit,
        not the end of its stdout: a child it left behind may hold that pipe open."""
        drain = asyncio.create_task(_drain(proc))
        try:
            code = f"exit code {await proc.exited}"
        finally:
            drain.cancel()
        while not self.stopping:
            quick = time.monotonic() - worker.started < QUICK_EXIT
            worker.quick_exits = worker.quick_exits + 1 if quick else 0
            if worker.quick_exits >= MAX_QUICK_EXITS:
                self.failed = (f"worker {worker.index} keeps exiting ({code}, "
                               f"{MAX_QUICK_EXITS} times in a row); stopping")
                log.error("%s", self.failed)
                self._gave_up.set()
                return
            pause = min(RESTART_PAUSE[0] * 2**worker.quick_exits, RESTART_PAUSE[1])
            log.warning("worker %d exited (%s); restarting it in %.1f s",
                        worker.index, code, pause)
            await asyncio.sleep(pause)
            if self.stopping:
                return
            try:
                await self._spawn(worker)  # which watches the new process
                return
            except OSError as exc:
                log.error("%s", exc)
                code = "it did not start"

    async def wait(self, status: str = "") -> None:
        """Until Ctrl-C/SIGTERM, or until a worker cannot be kept running (systemd told that
        the service is ready, then that it stops)."""
        stop = asyncio.create_task(serve_until_terminated(status))
        gave_up = asyncio.create_task(self._gave_up.wait())
        await asyncio.wait({stop, gave_up}, return_when=asyncio.FIRST_COMPLETED)
        for task in (stop, gave_up):
            task.cancel()
        await asyncio.gather(stop, gave_up, return_exceptions=True)  # STOPPING=1 sent

    async def stop(self) -> None:
        self.stopping = True
        procs = [w.proc for w in self.workers if w.proc is not None]
        await asyncio.gather(*(_terminate(p) for p in procs))
        for task in list(self._watchers):
            task.cancel()
        for sock in self._reserved:
            sock.close()
        self._reserved.clear()
        if self._dir:
            shutil.rmtree(self._dir, ignore_errors=True)


class WorkerProcess(asyncio.subprocess.Process):
    """A worker's process with ``exited``: its exit code as soon as it exits. asyncio's own
    ``wait()`` also waits for its pipes to close, which a child left behind can hold open."""

    exited: asyncio.Future[int]


class _WorkerProtocol(asyncio.subprocess.SubprocessStreamProtocol):
    def __init__(self, limit: int, loop: asyncio.AbstractEventLoop):
        super().__init__(limit=limit, loop=loop)
        self.exited: asyncio.Future[int] = loop.create_future()
        self._process: asyncio.SubprocessTransport | None = None

    def connection_made(self, transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._process = transport

    def process_exited(self) -> None:
        super().process_exited()
        if not self.exited.done() and self._process is not None:
            self.exited.set_result(self._process.get_returncode())


async def start_worker(command: list[str], env: dict[str, str]) -> WorkerProcess:
    """Start a worker: stdin a pipe from us (its end tells it we are gone), stdout a pipe to
    us (its address), in its own session (Ctrl-C reaches the parent, which stops the workers);
    without ``NOTIFY_SOCKET``: only the parent speaks to systemd; ``env`` added."""
    loop = asyncio.get_running_loop()
    env = {**{k: v for k, v in os.environ.items() if k not in SYSTEMD_VARIABLES}, **env}
    transport, protocol = await loop.subprocess_exec(
        lambda: _WorkerProtocol(2**16, loop), *command, stdin=subprocess.PIPE,
        stdout=subprocess.PIPE, stderr=None, start_new_session=True, env=env,
    )
    proc = WorkerProcess(transport, protocol, loop)
    proc.exited = protocol.exited
    return proc


async def _drain(proc: WorkerProcess) -> None:
    """Keep reading a worker's stdout, so that it never blocks on a full pipe."""
    assert proc.stdout is not None
    while await proc.stdout.read(2**16):
        pass


async def _terminate(proc: WorkerProcess) -> None:
    """SIGTERM, then SIGKILL if the worker has not stopped in time."""
    if not proc.exited.done():
        with contextlib.suppress(ProcessLookupError):
            proc.send_signal(signal.SIGTERM)
        try:
            await asyncio.wait_for(asyncio.shield(proc.exited), STOP_TIMEOUT)
        except TimeoutError:
            with contextlib.suppress(ProcessLookupError):
                proc.kill()
            await proc.exited


async def supervise(settings: Settings, argv: list[str]) -> None:
    """Run ``--workers N`` until Ctrl-C/SIGTERM; raises when the workers cannot run."""
    check_zenoh()
    supervisor = Supervisor(settings, argv)
    try:
        await supervisor.start()
        ws, tcp = settings.transport.schemes()
        address = settings.transport.address
        tcp_text = f"  {tcp}://{address}:{supervisor.tcp_port}" if supervisor.tcp_port else ""
        banner = (f"hitrobot-server {__version__}: {ws}://{address}:{supervisor.port}"
                  f"{tcp_text}  ({supervisor.count} workers)")
        print(banner, flush=True)
        await supervisor.wait(banner)
    finally:
        await supervisor.stop()
    if supervisor.failed:
        raise OSError(supervisor.failed)

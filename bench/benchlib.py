"""What every scenario of the loopback benchmarks shares: the server under test in its own
process (on 127.0.0.1, an ephemeral port, and a temporary state folder of its own), the bare
ceiling server's start, the pre-encoded LaserScan source, CPU metering, the printed tables and
the command line every scenario script takes (``--quick``, ``--profile-server``,
``--server-args``, ``--record``).

Figures only: no assertions, no pass/fail. Every loop is bounded in count and in time."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import itertools
import os
import platform
import re
import resource
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import orjson
from wsclient import HOST, RawWs, perf

from hitrobot_server import procmem

SERVER_ARGS: list[str] = []  # --server-args: more flags for every hitrobot-server started
ROOT = Path(__file__).resolve().parent.parent
BENCH = Path(__file__).resolve().parent


# ======================================================================= server processes
class ServerProc:
    """A server in a child process on an ephemeral loopback port, with its CPU time."""

    def __init__(self, argv: list[str], pattern: str, label: str, tree: str | None = None,
                 scratch: str | None = None):
        """``scratch``: a temporary folder of this server's own, removed when it stops."""
        self.scratch = scratch
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        if tree is not None:
            env["PYTHONPATH"] = str(Path(tree).resolve())
        self.label = label
        self.proc = subprocess.Popen(
            argv,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=env,
            cwd=tree or ROOT,
        )
        self.output: list[str] = []
        deadline = time.monotonic() + 30
        self.port = None
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            self.output.append(line)
            m = re.search(pattern, line)
            if m:
                self.port = int(m.group(1))
                break
        if self.port is None:
            self.stop()
            raise RuntimeError(f"{label} did not start:\n" + "".join(self.output))
        # keep draining its output so a chatty server never blocks on a full pipe
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self) -> None:
        for line in self.proc.stdout:
            self.output.append(line)

    def cpu(self) -> float:
        """User+system CPU seconds of the process so far."""
        try:
            fields = Path(f"/proc/{self.proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
            return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except (OSError, IndexError, ValueError):
            return float("nan")

    def _pids(self) -> list[int]:
        """The server and its worker processes (the pool that parses and encodes big ops)."""
        return [self.proc.pid, *procmem.children(self.proc.pid)]

    def rss_mb(self) -> float:
        """Peak resident set size (VmHWM) of the server plus each worker's peak, MB (the peaks
        may be at different times: an upper bound of the peak of the sum)."""
        return sum(procmem.peak_bytes(pid) for pid in self._pids()) / 2**20

    def rss_now_mb(self) -> float:
        """Resident set size right now (VmRSS) of the server and its workers, MB."""
        return sum(procmem.rss_bytes(pid) for pid in self._pids()) / 2**20

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        if self.scratch is not None:
            shutil.rmtree(self.scratch, ignore_errors=True)
            self.scratch = None


RECORD_DIR: str | None = None  # set by --record
_record_runs = itertools.count()


def ours_argv(extra: list[str] | tuple, tag: str, scratch: str) -> list[str]:
    """hitrobot-server's arguments: loopback, ephemeral ports, the bridge alone (no simulator
    competing for the core), its state, maps and recordings in ``scratch``; ``extra`` last."""
    folder = Path(scratch)
    args = ["-m", "hitrobot_server", "--port", "0", "--tcp-port", "0", "--address", HOST,
            "--log-level", "warning", "--robot", "none",
            "--state-dir", str(folder / "state"), "--map-dir", str(folder / "maps"),
            "--record-dir", str(folder / "recordings"), *SERVER_ARGS, *extra]
    if RECORD_DIR:  # --record: every server also records everything it carries
        args += ["--record", str(Path(RECORD_DIR) / f"{tag}_{next(_record_runs)}.mcap")]
    return args


def start_ours(profile_dir: str | None, tag: str, extra: list[str] | tuple = (),
               tree: str | None = None) -> ServerProc:
    """hitrobot-server with the bench's flags, ``extra`` flags after them; ``tree``: run the
    package from that source tree instead of this one (e.g. main's, for a before/after run)."""
    scratch = tempfile.mkdtemp(prefix="bench-server-")
    args = ours_argv(extra, tag, scratch)
    if profile_dir:
        Path(profile_dir).mkdir(parents=True, exist_ok=True)
        args = ["-m", "cProfile", "-o", str(Path(profile_dir) / f"{tag}.prof"), *args]
    return ServerProc([sys.executable, *args], r"ws://[\d.]+:(\d+)", "hitrobot-server", tree,
                      scratch)


def start_ceiling(lib: str = "websockets") -> ServerProc:
    """The bare broadcast server of bench_ceiling.py (``lib``: websockets or picows)."""
    return ServerProc(
        [sys.executable, str(BENCH / "bench_ceiling.py"), "--serve", lib],
        r"ceiling ws://[\d.]+:(\d+)",
        "ceiling server",
    )


# ======================================================================= output helpers
def table(headers: list[str], rows: list[list]) -> str:
    cells = [[str(h) for h in headers]] + [[str(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    lines = []
    for k, r in enumerate(cells):
        lines.append(
            "  "
            + "  ".join(
                c.rjust(w) if j else c.ljust(w)
                for j, (c, w) in enumerate(zip(r, widths, strict=True))
            )
        )
        if k == 0:
            lines.append("  " + "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def pct(values, q: float) -> float:
    return float(np.percentile(np.asarray(values), q)) if len(values) else float("nan")


def fnum(x: float, digits: int = 0) -> str:
    if x != x:  # nan
        return "n/a"
    return f"{x:,.{digits}f}"


class CpuMeter:
    """Server CPU seconds and this (client) process's CPU seconds over a measured window."""

    def __init__(self, server: ServerProc):
        self.server = server

    def __enter__(self) -> CpuMeter:
        self.s0, self.c0, self.t0 = self.server.cpu(), time.process_time(), perf()
        return self

    def __exit__(self, *exc) -> None:
        self.wall = perf() - self.t0
        self.server_s = self.server.cpu() - self.s0
        self.client_s = time.process_time() - self.c0

    def pcts(self, wall: float | None = None) -> tuple[str, str]:
        w = wall or self.wall
        return f"{100 * self.server_s / w:.0f}%", f"{100 * self.client_s / w:.0f}%"


def machine_info() -> None:
    import PIL
    import websockets

    model = ""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    try:
        from hitrobot_server import __version__ as ours
    except Exception:
        ours = "?"
    print(
        f"machine: {os.cpu_count()} cores ({model or platform.machine()}), "
        f"{platform.system()} {platform.release()}"
    )
    print(
        f"python {platform.python_version()} ({platform.python_implementation()}), "
        f"websockets {websockets.__version__}, orjson {orjson.__version__}, "
        f"numpy {np.__version__}, pillow {PIL.__version__}, hitrobot-server {ours}"
    )
    print(
        "setup: loopback 127.0.0.1, ephemeral ports; each server (ours and the ceiling) runs "
        "in its OWN process, the\n       measuring clients in this one (asyncio, raw "
        "header-parsing WS clients) - client and server do not share\n       an event loop "
        "or a core's loop. srv/cli CPU = CPU time / wall time of the measured window "
        "(100% = one core)."
    )

# ======================================================================= LaserScans
class ScanSource:
    """Pre-encoded LaserScan publish ops: a pool of pre-encoded 720-value ``ranges`` arrays
    joined with a per-message ``header.seq`` (a bytes concatenation, not a JSON encode).
    Ranges are float32 values printed as doubles, as rosbridge sends them (2.3450000286102295).
    """

    def __init__(self, topic: str, pool: int = 64):
        rng = np.random.default_rng(3)
        self.ranges = [
            orjson.dumps(rng.uniform(0.1, 30.0, 720).astype(np.float32).astype(float).tolist())
            for _ in range(pool)
        ]
        msg = {
            "header": {"seq": 0, "stamp": {"secs": 1_700_000_000, "nsecs": 0}, "frame_id": "laser"},
            "angle_min": -3.141592653589793,
            "angle_max": 3.141592653589793,
            "angle_increment": 0.008726646259971648,
            "time_increment": 0.0,
            "scan_time": 0.1,
            "range_min": 0.1,
            "range_max": 30.0,
            "ranges": "@RANGES@",
            "intensities": [],
        }
        text = orjson.dumps({"op": "publish", "topic": topic, "msg": msg})
        self.prefix, rest = text.split(b'"seq":0', 1)
        self.prefix += b'"seq":'
        self.mid, self.suffix = rest.split(b'"@RANGES@"', 1)

    def frame(self, seq: int) -> bytes:
        return b"".join(
            (
                self.prefix,
                str(seq).encode(),
                self.mid,
                self.ranges[seq % len(self.ranges)],
                self.suffix,
            )
        )


def verify_scan_samples(clients: list[RawWs], topic: str, count: int) -> tuple[int, int, int]:
    """Decode the kept samples: (checked, bad, frame_size of one verified sample)."""
    checked = bad = size = 0
    for c in clients:
        last_seq = -1
        for payload in c.samples:
            checked += 1
            try:
                op = orjson.loads(payload)
                seq = op["msg"]["header"]["seq"]
                ok = (
                    op["op"] == "publish"
                    and op["topic"] == topic
                    and len(op["msg"]["ranges"]) == 720
                    and 0 <= seq < count
                    and seq > last_seq
                )
                last_seq = seq
            except Exception:
                ok = False
            bad += not ok
            size = size or len(payload)
    return checked, bad, size


# ======================================================================= configuration
@dataclass
class Config:
    """The counts and bounds of every scenario (``--quick``: smaller), and the run's options."""

    quick: bool = False
    windows: tuple = (16, 128)  # in-flight limits; window 1 is the ping-pong run
    relay_count: int = 150_000
    relay_seconds: float = 5.0
    ping_count: int = 10_000
    ping_seconds: float = 3.0
    # LaserScan messages per run, per client count (more for fewer clients, so that every run
    # lasts long enough to time; the ceiling runs use the same counts)
    scan_counts: dict = field(default_factory=lambda: {1: 30_000, 10: 8_000, 50: 2_000})
    fanout_seconds: float = 6.0  # the publisher stops after this, whatever the count
    fanout_reps: int = 3
    clients: tuple = (1, 10, 50)
    fanout_timeout: float = 15.0  # after the last publish
    map_size: int = 2000
    map_reps: int = 3
    map_timeout: float = 60.0
    probe_map_sizes: tuple = (2000, 4000)
    probe_map_reps: int = 4
    idle_clients: int = 1000
    stall_seconds: float = 30.0
    stall_rate: int = 500  # LaserScans per second
    profile: str | None = None
    compare: list[str] | None = None
    compare_tree: str | None = None
    compare_label: str = "other"
    ceiling_lib: str = "websockets"


def config(quick: bool) -> Config:
    if not quick:
        return Config()
    return Config(
        quick=True, relay_count=30_000, relay_seconds=1.5, ping_count=3_000, ping_seconds=1.0,
        scan_counts={1: 12_000, 10: 3_000, 50: 800}, fanout_seconds=3.0, fanout_reps=1,
        map_reps=1, probe_map_reps=2, stall_seconds=10.0)


# ======================================================================= command line
def parser(description: str, fanout: bool = False) -> argparse.ArgumentParser:
    """The flags every scenario script takes; ``fanout``: also the LaserScan fan-out's."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--quick", action="store_true", help="a short run with smaller counts")
    p.add_argument("--profile-server", metavar="DIR",
                   help="run each hitrobot-server under cProfile, writing DIR/<run>.prof")
    p.add_argument("--server-args", default="", metavar="ARGS",
                   help="more flags for each hitrobot-server, e.g. '--event-loop asyncio'")
    p.add_argument("--record", action="store_true",
                   help="run every hitrobot-server with --record (into a temporary folder), to "
                   "compare the figures with and without recording")
    if fanout:
        p.add_argument("--compare", metavar="ARGS",
                       help="fan-out: also run a second hitrobot-server with these extra flags "
                       "(e.g. '--no-send-window'), interleaved with the first, and print the two "
                       "side by side")
        p.add_argument("--compare-tree", metavar="DIR",
                       help="fan-out: the second server runs from this source tree (e.g. a "
                       "checkout of main: before/after in one run); with or without --compare")
        p.add_argument("--clients", default="1,10,50",
                       help="fan-out subscriber counts, e.g. 1 (default 1,10,50)")
    return p


def ceiling_lib_flag(p: argparse.ArgumentParser) -> None:
    """``--ceiling-lib``: which bare server the ceiling runs."""
    p.add_argument("--ceiling-lib", choices=("websockets", "picows"), default="websockets",
                   help="the ceiling's bare server: websockets (ours is built on it) or "
                   "picows (pip install picows; what a faster WebSocket layer gives)")


def settings(args: argparse.Namespace) -> Config:
    """The run's Config from the parsed flags; ``--server-args`` applied to every server."""
    cfg = config(args.quick)
    cfg.profile = args.profile_server
    if hasattr(args, "clients"):
        cfg.clients = tuple(int(n) for n in args.clients.split(","))
        cfg.compare = (shlex.split(args.compare or "")
                       if args.compare is not None or args.compare_tree else None)
        cfg.compare_tree = args.compare_tree
        cfg.compare_label = " ".join(
            ([f"tree {Path(args.compare_tree).name}"] if args.compare_tree else [])
            + (cfg.compare or [])) or "other"
    cfg.ceiling_lib = getattr(args, "ceiling_lib", cfg.ceiling_lib)
    SERVER_ARGS.extend(shlex.split(args.server_args))
    return cfg


async def _scenarios(cfg: Config, body: Callable[[Config], Awaitable[list[str]]]) -> None:
    t_start = perf()
    machine_info()
    print(
        f"mode: {'--quick' if cfg.quick else 'full'}"
        + (f"; hitrobot-server runs under cProfile (slower!), profiles in {cfg.profile}/"
           if cfg.profile else "")
    )
    summary = await body(cfg)
    print("\n== summary " + "=" * 60)
    for line in summary:
        print("  " + line)
    print(f"  total bench time {perf() - t_start:.1f} s")


def run_main(args: argparse.Namespace,
             body: Callable[[Config], Awaitable[list[str]]]) -> int:
    """Run ``body`` (scenarios printing their tables, returning summary lines) with the
    machine's description first and the summary last; ``--record`` into a temporary folder."""
    global RECORD_DIR
    with contextlib.suppress(ValueError, OSError):  # 1000 idle clients need the file handles
        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, min(hard, 8192)), hard))
    cfg = settings(args)
    with tempfile.TemporaryDirectory(prefix="bench-record-") as folder:
        RECORD_DIR = folder if args.record else None
        if args.record:
            print(f"every server records (--record) into {folder}")
        asyncio.run(_scenarios(cfg, body))
    return 0

#!/usr/bin/env python3
"""An hour's soak of hitrobot-server with every topic recorded: is every process flat?

Starts the real server (``python -m hitrobot_server``, simulated robot, ``--record`` of every
topic, temporary state/map/recording folders, ephemeral loopback ports) and, for ``--minutes``,
runs operators that churn: each connects over WebSocket or raw TCP, subscribes to /scan /odom
/map /tf, calls /rosapi/get_time, adds and deletes a POI (acknowledged by a status), publishes
/cmd_vel, then disconnects and comes back. A witness in its own process subscribes to /odom for
the whole run and measures its rate and worst gap. Every ``--interval`` seconds the resident
memory (RSS, and PSS/USS from smaps_rollup) of every process of the server's tree is sampled
by role: main, recorder writer, offload pool worker, resource tracker.

At the end it prints the counts, the witness's figures, per process RSS at start, at the end of
the warm-up, min/max after it and the least-squares slope after it (MB/hour), and the
recording's size and message count read back with the ``mcap`` reader. Prints figures; asserts
nothing. Loopback only; every loop is bounded in count and in time; the temporary folders are
removed at the end.

    .venv/bin/python bench/soak.py                  # one hour (10 min warm-up)
    .venv/bin/python bench/soak.py --minutes 3      # a trial
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import itertools
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from websockets.asyncio.client import connect

from hitrobot_server import procmem

HOST = "127.0.0.1"
MB = 2**20
ODOM = "/odom"
TOPICS = ("/scan", ODOM, "/map", "/tf")
CALL_TIMEOUT = 10.0
ROOT = Path(__file__).resolve().parent.parent


# ======================================================================= the server
class Server:
    """The server in a child process; its output drained into a bounded tail."""

    def __init__(self, folder: Path):
        self.record = folder / "rec" / "soak.mcap"
        self.record.parent.mkdir(parents=True)
        argv = [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "-1",
                "--address", HOST, "--robot", "sim", "--log-level", "warning",
                "--state-dir", str(folder / "state"), "--map-dir", str(folder / "maps"),
                "--record-dir", str(self.record.parent), "--record", str(self.record)]
        self.proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True, cwd=ROOT,
                                     env={**os.environ, "PYTHONUNBUFFERED": "1"})
        self.tail: deque[str] = deque(maxlen=200)
        deadline = time.monotonic() + 60
        self.port = self.tcp_port = 0
        while time.monotonic() < deadline and not self.port:
            line = self.proc.stdout.readline()
            if not line:
                break
            self.tail.append(line)
            if m := re.search(r"ws://[\d.]+:(\d+)\s+tcp://[\d.]+:(\d+)", line):
                self.port, self.tcp_port = int(m.group(1)), int(m.group(2))
        if not self.port:
            self.stop()
            raise RuntimeError("the server did not start:\n" + "".join(self.tail))
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self) -> None:
        for line in self.proc.stdout:
            self.tail.append(line)

    def stop(self) -> int | None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(60)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
        return self.proc.returncode


# ======================================================================= memory
def _stat(pid: int) -> list[str]:
    return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()


def smaps(pid: int) -> tuple[int, int]:
    """(PSS, USS) bytes from smaps_rollup; (0, 0) when unreadable."""
    pss = uss = 0
    try:
        for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
            key, _, rest = line.partition(":")
            if key == "Pss":
                pss = int(rest.split()[0]) * 1024
            elif key in ("Private_Clean", "Private_Dirty"):
                uss += int(rest.split()[0]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return pss, uss


def role(pid: int, main_nice: int) -> str:
    """What a child of the server is: by its command line, and for the spawned ones by the
    niceness they set themselves (recorder writer +5, offload pool +10)."""
    try:
        cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
        nice = int(_stat(pid)[16])
    except (OSError, ValueError, IndexError):
        return "gone"
    if "resource_tracker" in cmd:
        return "resource tracker"
    if "spawn_main" in cmd:
        return {5: "recorder writer", 10: "offload pool"}.get(nice - main_nice, "spawned")
    return "child"


@dataclass
class Series:
    samples: list[tuple[float, float, float, float]] = field(default_factory=list)


def sample(main: int, start: float, series: dict[str, Series]) -> None:
    """One sample of every process of the tree, keyed by role and pid."""
    try:
        main_nice = int(_stat(main)[16])
    except (OSError, ValueError, IndexError):
        return
    t = time.monotonic() - start
    kids = procmem.children(main)
    for pid in [main, *kids, *itertools.chain.from_iterable(map(procmem.children, kids))]:
        name = "main" if pid == main else role(pid, main_nice)
        rss = procmem.rss_bytes(pid)
        if not rss or name in ("gone", "spawned"):  # spawned: not yet its niceness
            continue
        pss, uss = smaps(pid)
        series.setdefault(f"{name} [{pid}]", Series()).samples.append(
            (t, rss / MB, pss / MB, uss / MB))


async def sampler(main: int, start: float, interval: float, stop: asyncio.Event,
                  series: dict[str, Series]) -> None:
    while not stop.is_set():
        await asyncio.to_thread(sample, main, start, series)
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(stop.wait(), interval)
    await asyncio.to_thread(sample, main, start, series)


# ======================================================================= clients
@dataclass
class Counts:
    connections: dict[str, int] = field(default_factory=lambda: {"ws": 0, "tcp": 0})
    calls: int = 0
    poi_changes: int = 0
    publishes: int = 0
    messages: int = 0
    bytes: int = 0
    failures: list[str] = field(default_factory=list)

    def fail(self, what: str) -> None:
        if len(self.failures) < 10_000:
            self.failures.append(what)


class Link:
    """One operator connection, WebSocket or raw TCP, with the replies it waits for."""

    def __init__(self, kind: str, counts: Counts):
        self.kind, self.counts = kind, counts
        self.waiting: dict[str, asyncio.Future] = {}
        self.ws = self.reader = self.writer = None
        self.task: asyncio.Task | None = None

    async def open(self, server: Server) -> None:
        if self.kind == "ws":
            self.ws = await connect(f"ws://{HOST}:{server.port}", max_size=None,
                                    open_timeout=CALL_TIMEOUT)
        else:
            self.reader, self.writer = await asyncio.wait_for(asyncio.open_connection(
                HOST, server.tcp_port, limit=2**27), CALL_TIMEOUT)
        self.counts.connections[self.kind] += 1
        self.task = asyncio.create_task(self._read())

    async def send(self, op: dict) -> None:
        text = json.dumps(op)
        if self.ws is not None:
            await self.ws.send(text)
        else:
            self.writer.write(text.encode() + b"\n")
            await self.writer.drain()

    async def _read(self) -> None:
        while True:
            if self.ws is not None:
                data = await self.ws.recv()
            else:
                data = await self.reader.readline()
                if not data:
                    return
            self.counts.messages += 1
            self.counts.bytes += len(data)
            head = data[:40] if isinstance(data, str) else data[:40].decode("latin-1")
            if head.startswith('{"op":"publish"'):
                continue
            reply = json.loads(data)
            future = self.waiting.pop(str(reply.get("id")), None)
            if future is not None and not future.done():
                future.set_result(reply)

    async def ask(self, op: dict) -> dict:
        future = asyncio.get_running_loop().create_future()
        self.waiting[op["id"]] = future
        await self.send(op)
        try:
            return await asyncio.wait_for(future, CALL_TIMEOUT)
        finally:
            self.waiting.pop(op["id"], None)

    async def close(self) -> None:
        if self.task is not None:
            self.task.cancel()
        if self.ws is not None:
            await self.ws.close()
        elif self.writer is not None:
            self.writer.close()


async def session(link: Link, name: str, seconds: float) -> None:
    """One operator's visit: subscribe, then calls, POI changes and /cmd_vel until it leaves."""
    c = link.counts
    await link.send({"op": "set_level", "level": "info"})
    for topic in TOPICS:
        await link.send({"op": "subscribe", "topic": topic})
    await link.send({"op": "advertise", "topic": "/cmd_vel", "type": "geometry_msgs/Twist"})
    ids = itertools.count()
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        n = next(ids)
        reply = await link.ask({"op": "call_service", "service": "/rosapi/get_time",
                                "id": f"t{n}"})
        c.calls += 1
        if not reply.get("result"):
            c.fail(f"get_time: {reply}")
        if n % 10 == 3:
            await poi_round_trip(link, f"{name}_{n}", n)
        for _ in range(3):
            await link.send({"op": "publish", "topic": "/cmd_vel", "msg": {
                "linear": {"x": 0.0, "y": 0.0, "z": 0.0},
                "angular": {"x": 0.0, "y": 0.0, "z": random.choice((-0.2, 0.2))}}})
            c.publishes += 1
            await asyncio.sleep(0.3)


async def poi_round_trip(link: Link, name: str, n: int) -> None:
    """Add a POI and delete it, each acknowledged (a status at level info) once durable."""
    c = link.counts
    for topic, type_name, msg in (
        ("/map_manager/add_poi", "map_messages/PointOfInterest", {
            "type": 100, "name": name, "remarks": "soak", "pose": {
                "position": {"x": 3.0, "y": 8.0, "z": 0.0},
                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}),
        ("/map_manager/delete_poi", "map_messages/DeletePointOfInterest", {"name": name}),
    ):
        await link.send({"op": "advertise", "topic": topic, "type": type_name})
        status = await link.ask({"op": "publish", "topic": topic, "msg": msg,
                                 "id": f"p{n}{topic[-7:]}"})
        c.poi_changes += 1
        if status.get("level") != "info":
            c.fail(f"{topic}: {status}")


async def operator(server: Server, index: int, deadline: float, counts: Counts) -> None:
    """Visit after visit until the deadline, alternating WebSocket and TCP."""
    rnd = random.Random(index)
    await asyncio.sleep(rnd.uniform(0, 10))
    for visit in range(100_000):
        left = deadline - time.monotonic()
        if left < 5:
            return
        link = Link("ws" if (index + visit) % 3 else "tcp", counts)
        try:
            await link.open(server)
            await session(link, f"soak{index}_{visit}", min(left - 2, rnd.uniform(20, 60)))
        except (OSError, TimeoutError, ConnectionError, ValueError) as exc:
            counts.fail(f"{link.kind}: {type(exc).__name__}: {exc}")
        except Exception as exc:  # noqa: BLE001  a closed websocket and the like: counted
            counts.fail(f"{link.kind}: {type(exc).__name__}: {exc}")
        finally:
            await link.close()
        await asyncio.sleep(rnd.uniform(1, 3))


# ======================================================================= the witness
def witness_main(port: int, seconds: float) -> None:
    """Own process: subscribe to /odom for ``seconds``; print rate and worst gap as JSON."""

    async def main() -> dict:
        times: list[float] = []
        async with connect(f"ws://{HOST}:{port}", max_size=None) as ws:
            await ws.send(json.dumps({"op": "subscribe", "topic": ODOM}))
            end = time.monotonic() + seconds
            while (left := end - time.monotonic()) > 0:
                try:
                    data = await asyncio.wait_for(ws.recv(), min(left, 30))
                except TimeoutError:
                    continue
                if f'"topic":"{ODOM}"' in data[:60]:
                    times.append(time.monotonic())
        gaps = np.diff(times) if len(times) > 1 else np.array([0.0])
        span = times[-1] - times[0] if len(times) > 1 else 1.0
        return {"messages": len(times), "rate": (len(times) - 1) / span,
                "worst_gap_ms": float(gaps.max() * 1000),
                "p99_gap_ms": float(np.percentile(gaps, 99) * 1000),
                "gaps_over_250ms": int((gaps > 0.25).sum())}

    print(json.dumps(asyncio.run(main())), flush=True)


# ======================================================================= the report
def slope(points: list[tuple[float, float]]) -> float:
    """Least-squares slope, MB per hour (nan for fewer than 3 points)."""
    if len(points) < 3:
        return float("nan")
    t, y = np.array(points).T
    return float(np.polyfit(t / 3600, y, 1)[0])


def memory_table(series: dict[str, Series], warmup: float, idle: float) -> list[str]:
    head = (f"{'process':<26}{'n':>4}{'RSS start':>10}{'@warm-up':>10}{'min after':>10}"
            f"{'max after':>10}{'max-min':>9}{'slope MB/h':>11}{'PSS end':>9}{'USS end':>9}"
            f"{'USS slope':>10}{'idle max-min':>13}{'idle slope':>11}")
    lines = [head, "-" * len(head)]
    for name, s in series.items():
        after = [x for x in s.samples if warmup <= x[0] <= idle + 1]  # under load
        first = s.samples[0]
        rss = [x[1] for x in after] or [float("nan")]
        at_warm = after[0][1] if after else float("nan")
        last = s.samples[-1]
        lines.append(
            f"{name:<26}{len(s.samples):>4}{first[1]:>10.1f}{at_warm:>10.1f}{min(rss):>10.1f}"
            f"{max(rss):>10.1f}{max(rss) - min(rss):>9.1f}"
            f"{slope([(x[0], x[1]) for x in after]):>11.2f}{last[2]:>9.1f}{last[3]:>9.1f}"
            f"{slope([(x[0], x[3]) for x in after]):>10.2f}"
            f"{_spread([x[1] for x in s.samples if x[0] >= idle]):>13.1f}"
            f"{slope([(x[0], x[1]) for x in s.samples if x[0] >= idle]):>11.2f}"
            f"   (seen {first[0] / 60:.1f}-{last[0] / 60:.1f} min)")
    return lines


def _spread(values: list[float]) -> float:
    return max(values) - min(values) if values else float("nan")


def recording_figures(folder: Path) -> list[str]:
    """Each recorded file's size and the messages read back from it with the mcap reader."""
    lines, total, size = [], 0, 0
    for path in sorted(folder.glob("*.mcap")):
        count, topics = 0, set()
        try:
            with path.open("rb") as f:
                for _schema, channel, _message in make_reader(f).iter_messages():
                    count += 1
                    topics.add(channel.topic)
            ok = "reads back"
        except Exception as exc:  # noqa: BLE001  the figure is what failed
            ok = f"FAILED to read back: {type(exc).__name__}: {exc}"
        lines.append(f"  {path.name}: {path.stat().st_size / MB:.1f} MiB, {count} messages on "
                     f"{len(topics)} topics, {ok}")
        total += count
        size += path.stat().st_size
    lines.append(f"  total: {size / MB:.1f} MiB in {len(lines)} file(s), {total} messages")
    return lines


def print_report(cfg, counts: Counts, witness: dict, series: dict[str, Series],
                 recording: list[str], elapsed: float, rc: int | None, tail: list[str]) -> None:
    warmup = cfg.warmup * 60
    print(f"\n=== soak: {elapsed / 60:.1f} min of load, {cfg.operators} operators, warm-up "
          f"{cfg.warmup:g} min, a sample every {cfg.interval:g} s, then {cfg.idle_minutes:g} min "
          "idle with recording on (a busy 2-core machine)")
    print(f"connections: {sum(counts.connections.values())} ({counts.connections['ws']} "
          f"WebSocket, {counts.connections['tcp']} TCP)")
    print(f"calls /rosapi/get_time: {counts.calls}; POI add+delete (acknowledged): "
          f"{counts.poi_changes}; /cmd_vel publishes: {counts.publishes}")
    print(f"delivered to operators: {counts.messages} messages, {counts.bytes / 1e9:.2f} GB")
    print(f"failures: {len(counts.failures)}")
    for what in counts.failures[:10]:
        print(f"  {what[:200]}")
    print(f"witness {ODOM}: {witness}")
    print("\nmemory per process (MB; 'after' = from the warm-up's end to the load's end; "
          "'idle' = from the load's end on):")
    print("\n".join(memory_table(series, warmup, elapsed)))
    print(f"\nrecording (server exit code {rc}):")
    print("\n".join(recording))
    errors = [i for i, line in enumerate(tail) if "ERROR" in line or "Traceback" in line]
    print(f"server log: {len(errors)} error line(s) in its last {len(tail)} lines")
    if errors:  # the first one in full
        for line in tail[errors[0]:errors[0] + 40]:
            print(f"  {line.rstrip()[:200]}")


# ======================================================================= main
async def load(server: Server, cfg, series: dict[str, Series]) -> tuple[Counts, dict, float]:
    counts = Counts()
    start = time.monotonic()
    seconds = cfg.minutes * 60
    witness = await asyncio.create_subprocess_exec(
        sys.executable, str(Path(__file__).resolve()), "--witness", str(server.port),
        str(seconds + cfg.idle_minutes * 60), stdout=asyncio.subprocess.PIPE)
    stop = asyncio.Event()
    sampling = asyncio.create_task(sampler(server.proc.pid, start, cfg.interval, stop, series))
    deadline = start + seconds
    await asyncio.gather(*(operator(server, i, deadline, counts)
                           for i in range(cfg.operators)))
    elapsed = time.monotonic() - start
    out, _ = await asyncio.wait_for(witness.communicate(), cfg.idle_minutes * 60 + 120)
    stop.set()
    await sampling
    try:
        result = json.loads(out.decode().strip().splitlines()[-1])
    except (ValueError, IndexError):
        result = {"error": out.decode()[-500:]}
    return counts, result, elapsed


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=60.0, help="minutes of load")
    ap.add_argument("--warmup", type=float, default=None,
                    help="minutes of warm-up (default 10, or a third of a shorter run)")
    ap.add_argument("--idle-minutes", type=float, default=0.0,
                    help="minutes without operators after the load (recording still on)")
    ap.add_argument("--operators", type=int, default=24)
    ap.add_argument("--interval", type=float, default=30.0, help="seconds between samples")
    ap.add_argument("--witness", nargs=2, metavar=("PORT", "SECONDS"), help=argparse.SUPPRESS)
    cfg = ap.parse_args()
    if cfg.witness:
        witness_main(int(cfg.witness[0]), float(cfg.witness[1]))
        return 0
    if cfg.warmup is None:
        cfg.warmup = min(10.0, cfg.minutes / 3)
    folder = Path(tempfile.mkdtemp(prefix="soak-"))
    try:
        server = Server(folder)
        series: dict[str, Series] = {}
        try:
            counts, witness, elapsed = asyncio.run(load(server, cfg, series))
        finally:
            rc = server.stop()
        print_report(cfg, counts, witness, series, recording_figures(server.record.parent),
                     elapsed, rc, list(server.tail))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

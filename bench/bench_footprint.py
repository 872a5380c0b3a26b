"""The server's footprint on the robot's computer: CPU (% of one core) and PSS of its whole
process tree while it idles, drives a REST robot, and serves idle or light clients; and what
500 idle connections cost. Side by side for this tree and another commit (``--against``).

    .venv/bin/python bench/bench_footprint.py                       # this tree, 30 s windows
    .venv/bin/python bench/bench_footprint.py --against HEAD~1 --seconds 15

Each case measures a window of ``--seconds`` after a warm-up (``--warmup``): the CPU time of
the server and its children (``/proc``), their wake-ups (context switches of every thread, per
second: the figure another engineer's load on a shared machine moves least), and their PSS
(``smaps_rollup``) at the end. The REST
robot is ``hitrobot-server sim-device`` in a process of its own (this tree's, not counted).
``--against REV`` runs the server of ``git archive REV hitrobot_server schemas``. Prints
figures, asserts nothing; loopback only; every wait is bounded.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import re
import subprocess
import sys
import tarfile
import tempfile
import threading
import time
from pathlib import Path

import websockets

ROOT = Path(__file__).resolve().parent.parent
TICK = os.sysconf("SC_CLK_TCK")
LIGHT = ("/odom", "nav_msgs/Odometry"), ("/tf", "tf2_msgs/TFMessage"), (
    "/scan", "sensor_msgs/LaserScan")


def tree(pid: int) -> list[int]:
    """``pid`` and its descendants."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            children.setdefault(ppid, []).append(int(entry))
    found, todo = [], [pid]
    while todo:
        p = todo.pop()
        found.append(p)
        todo += children.get(p, [])
    return found


def cpu_seconds(pids: list[int]) -> float:
    total = 0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += int(fields[11]) + int(fields[12])
    return total / TICK


def wakeups(pids: list[int]) -> int:
    """Context switches of every thread of ``pids``, all told (each wake-up is one)."""
    total = 0
    for pid in pids:
        try:
            tasks = os.listdir(f"/proc/{pid}/task")
        except OSError:
            continue
        for tid in tasks:
            try:
                text = Path(f"/proc/{pid}/task/{tid}/status").read_text()
            except OSError:
                continue
            total += sum(int(n) for n in re.findall(r"ctxt_switches:\s+(\d+)", text))
    return total


def pss_mb(pids: list[int]) -> float:
    total = 0
    for pid in pids:
        try:
            text = Path(f"/proc/{pid}/smaps_rollup").read_text()
        except OSError:
            continue
        match = re.search(r"^Pss:\s+(\d+) kB", text, re.M)
        total += int(match.group(1)) if match else 0
    return total / 1024


def start(args: list[str], code: Path, cwd: Path) -> tuple[subprocess.Popen, str]:
    """A ``hitrobot_server`` command; the first ws:// or http:// address it prints."""
    proc = subprocess.Popen([sys.executable, "-m", "hitrobot_server", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env={**os.environ, "PYTHONPATH": str(code)}, cwd=cwd)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        found = re.search(r"(ws|http)://127\.0\.0\.1:\d+", line)
        if found:  # its log goes on being read, or a full pipe would stall it
            threading.Thread(target=proc.stdout.read, daemon=True).start()
            return proc, found.group(0)
    proc.kill()
    raise RuntimeError(f"{args[:1]} did not start")


def stop(proc: subprocess.Popen) -> None:
    proc.terminate()
    try:
        proc.wait(15)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)


async def window(pid: int, seconds: float) -> str:
    pids = tree(pid)
    t0, c0, w0 = time.monotonic(), cpu_seconds(pids), wakeups(pids)
    await asyncio.sleep(seconds)
    pids = tree(pid)
    spent = time.monotonic() - t0
    cpu = 100 * (cpu_seconds(pids) - c0) / spent
    return f"{cpu:5.2f} % {(wakeups(pids) - w0) / spent:5.0f}/s {pss_mb(pids):4.0f} MB"


async def reader(ws) -> None:
    async for _message in ws:
        pass


async def cases(code: Path, folder: Path, seconds: float, warmup: float) -> dict[str, str]:
    base = ["--port", "0", "--tcp-port", "-1", "--address", "127.0.0.1",
            "--state-dir", str(folder / "state")]
    out: dict[str, str] = {}
    server, url = start([*base, "--robot", "none"], code, folder)
    idle: list = []
    try:
        await asyncio.sleep(warmup)
        out["the bridge alone (--robot none)"] = await window(server.pid, seconds)
        idle = [await websockets.connect(url) for _ in range(50)]
        await asyncio.sleep(warmup / 2)
        out["the bridge + 50 idle clients"] = await window(server.pid, seconds)
    finally:
        for ws in idle:
            await ws.close()
        stop(server)
    device, robot = start(["sim-device", "--port", "0"], ROOT, folder)
    server, url = start([*base, "--robot", robot], code, folder)
    clients: list = []
    tasks: list[asyncio.Task] = []
    try:
        await asyncio.sleep(warmup)
        out["driving a REST robot, no client"] = await window(server.pid, seconds)
        clients = [await websockets.connect(url, max_size=None) for _ in range(50)]
        await asyncio.sleep(warmup / 2)
        out["+ 50 idle WebSocket clients"] = await window(server.pid, seconds)
        for _ in range(10):
            ws = await websockets.connect(url, max_size=None)
            for topic, type_name in LIGHT:
                await ws.send(json.dumps({"op": "subscribe", "topic": topic,
                                          "type": type_name}))
            clients.append(ws)
            tasks.append(asyncio.create_task(reader(ws)))
        await asyncio.sleep(warmup / 2)
        out["+ 10 clients on /odom, /tf, /scan"] = await window(server.pid, seconds)
    finally:
        for task in tasks:
            task.cancel()
        for ws in clients:
            await ws.close()
        stop(server)
        stop(device)
    out["500 idle connections"] = await connections(code, folder, base)
    return out


async def connections(code: Path, folder: Path, base: list[str]) -> str:
    server, url = start([*base, "--robot", "none"], code, folder)
    clients = []
    try:
        await asyncio.sleep(2)
        before = pss_mb(tree(server.pid))
        t0 = time.monotonic()
        for _ in range(10):  # fifty handshakes at a time
            clients += await asyncio.gather(*(websockets.connect(url, open_timeout=60)
                                              for _ in range(50)))
        opened = time.monotonic() - t0
        await asyncio.sleep(2)
        each = (pss_mb(tree(server.pid)) - before) * 1024 / 500
        return f"opened in {opened:.2f} s | {each:.0f} kB each"
    finally:
        for ws in clients:
            await ws.close()
        stop(server)


def code_of(rev: str, folder: Path) -> Path:
    archive = folder / "code.tar"
    subprocess.run(["git", "-C", str(ROOT), "archive", "-o", str(archive), rev,
                    "hitrobot_server", "schemas"], check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(folder / "code", filter="data")
    return folder / "code"


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", metavar="REV", help="also the server of this commit")
    parser.add_argument("--seconds", type=float, default=30.0, help="each window (default 30)")
    parser.add_argument("--warmup", type=float, default=10.0, help="before it (default 10)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench_footprint_") as tmp:
        folder = Path(tmp)
        codes = {"this tree": ROOT}
        if args.against:
            codes[args.against] = code_of(args.against, folder)
        results = {name: await cases(code, folder, args.seconds, args.warmup)
                   for name, code in codes.items()}
    names = list(results)
    print(f"{'case':36} | " + " | ".join(f"{n + ' (CPU, wake-ups, PSS)':^28}" for n in names))
    for case in results[names[0]]:
        print(f"{case:36} | " + " | ".join(f"{results[n][case]:>28}" for n in names))


if __name__ == "__main__":
    asyncio.run(main())

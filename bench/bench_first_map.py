"""How long the first JSON subscriber to ``/map`` waits, against a later one (issue 49 item 6).

Each run starts ``hitrobot-server`` (the simulated robot, a temporary state folder, loopback)
as its own process and times: the start-up (process spawned to the banner), then for two
subscribers one after the other, each on its own connection, the time from sending
``subscribe /map`` (JSON) to its first ``/map`` message. The map is big enough (> 256 KB of
JSON) that its encoding is built in the server's worker pool. "pool warm" is how long the
pool took to warm in the background after the start began (the server logs it; 0: not
warmed). Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from websockets.asyncio.client import connect

START_TIMEOUT = 30.0
MAP_TIMEOUT = 30.0


def start(folder: str, extra: list[str]) -> tuple[subprocess.Popen, int, float]:
    """The server, its port and how long it took to print its banner."""
    log_path = Path(folder) / "server.log"
    t0 = time.perf_counter()
    with open(log_path, "w") as log:  # a file, not a pipe no one reads
        proc = subprocess.Popen(
            [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "-1",
             "--address", "127.0.0.1", "--state-dir", str(Path(folder) / "state"), *extra],
            stdout=log, stderr=subprocess.STDOUT)
    deadline = t0 + START_TIMEOUT
    while time.perf_counter() < deadline and proc.poll() is None:
        found = re.search(r"ws://127\.0\.0\.1:(\d+)", log_path.read_text())
        if found:
            return proc, int(found.group(1)), time.perf_counter() - t0
        time.sleep(0.005)
    proc.kill()
    raise SystemExit("the server did not start:\n" + log_path.read_text())


async def first_map(port: int) -> tuple[float, int]:
    """Seconds from ``subscribe`` to the first ``/map`` message, and its size."""
    async with connect(f"ws://127.0.0.1:{port}", max_size=None) as ws:
        t0 = time.perf_counter()
        await ws.send(json.dumps({"op": "subscribe", "topic": "/map"}))
        deadline = t0 + MAP_TIMEOUT
        while time.perf_counter() < deadline:
            frame = await asyncio.wait_for(ws.recv(), MAP_TIMEOUT)
            if '"topic":"/map"' in frame[:100]:
                return time.perf_counter() - t0, len(frame)
    raise SystemExit("no /map")


def warm_up(log: str) -> float:
    """How long the pool took to warm, as the server logs it (0: not warmed at start)."""
    found = re.search(r"worker pool warm: \d+ process\(es\) in (\d+) ms", log)
    return int(found.group(1)) / 1000 if found else 0.0


def one_run(extra: list[str]) -> tuple[float, float, float, float, int]:
    with tempfile.TemporaryDirectory(prefix="hitrobot-bench-") as folder:
        proc, port, startup = start(folder, extra)
        try:
            first, size = asyncio.run(first_map(port))
            later, _ = asyncio.run(first_map(port))
        finally:
            proc.terminate()
            try:
                proc.wait(30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(10)
        warm = warm_up((Path(folder) / "server.log").read_text())
    return startup, warm, first, later, size


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("extra", nargs="*", help="more server flags (after --)")
    args = parser.parse_args()
    rows = []
    for i in range(max(1, min(args.runs, 50))):
        startup, warm, first, later, size = one_run(args.extra)
        rows.append((startup, warm, first, later))
        print(f"run {i + 1}: start-up {startup * 1000:6.0f} ms (pool warm in {warm * 1000:4.0f})"
              f"   first /map {first * 1000:6.0f} ms   later /map {later * 1000:6.0f} ms"
              f"   ({size} bytes)")
    for name, col in (("start-up", 0), ("pool warm", 1), ("first /map", 2), ("later /map", 3)):
        values = [row[col] * 1000 for row in rows]
        print(f"{name:<11} median {statistics.median(values):6.0f} ms   "
              f"min {min(values):6.0f}   max {max(values):6.0f}")


if __name__ == "__main__":
    main()

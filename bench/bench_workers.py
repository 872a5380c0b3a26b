#!/usr/bin/env python3
"""``--workers N``: LaserScan fan-out to 400 clients behind one port, against one worker and
against a bare ``websockets`` broadcast server.

Prints figures only (no assertions). Loopback only, ephemeral ports, every loop bounded in count
and time. The server runs as its own process tree (``python -m hitrobot_server --workers N
--robot none``); the subscribers are spread over several client processes (this file with
``--client``), so that one client process is not the bottleneck; the publisher is this process.

    .venv/bin/python bench/bench_workers.py                  # --workers 1, 2, 4, … up to the cores
    .venv/bin/python bench/bench_workers.py --quick          # fewer messages
    .venv/bin/python bench/bench_workers.py --workers-list 1,2 --clients 400 --client-procs 4

For each run: messages delivered per second over all subscribers, the ratio to one worker and
to the bare server, the server processes' CPU (100% = one core) and the largest worker RSS.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from benchlib import (  # noqa: E402  (a sibling script, not a package)
    ScanSource,
    ServerProc,
    fnum,
    start_ceiling,
    table,
)
from wsclient import HOST, RawWs, barrier, close_all, ws_frame  # noqa: E402

TOPIC = "/bench/scan"
STALL = 2.0  # seconds without progress: the rest was dropped (slow-client policy)
SEND_BUFFER = "1000000"  # bytes queued per client: 400 clients stay within a few hundred MB


# ======================================================================= server processes
def start_workers(n: int) -> ServerProc:
    argv = [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "0",
            "--address", HOST, "--log-level", "warning", "--robot", "none",
            "--send-buffer-limit", SEND_BUFFER, "--workers", str(n)]
    return ServerProc(argv, r"ws://[\d.]+:(\d+)", f"hitrobot-server --workers {n}")


def tree(pid: int) -> list[int]:
    """``pid`` and its children (a --workers parent and its workers)."""
    try:
        children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    except OSError:
        children = []
    return [pid, *map(int, children)]


def cpu_seconds(pids: list[int]) -> float:
    total = 0.0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except (OSError, IndexError, ValueError):
            pass
    return total


def rss_mb(pid: int) -> float:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


# ======================================================================= client processes
def client_main(port: int, n: int) -> None:
    """Open ``n`` subscribers; report when each got a message, then count until told."""

    async def main() -> None:
        subs: list[RawWs] = []
        for k in range(0, n, 25):
            subs += await asyncio.gather(*(RawWs.open(port) for _ in range(min(25, n - k))))
        for s in subs:
            s.send({"op": "subscribe", "topic": TOPIC, "type": "sensor_msgs/LaserScan"})
        print("subscribed", flush=True)
        deadline = time.monotonic() + 60
        while min(s.count for s in subs) == 0 and time.monotonic() < deadline:
            await asyncio.sleep(0.02)
        print("warm", flush=True)
        loop = asyncio.get_running_loop()
        line = await loop.run_in_executor(None, sys.stdin.readline)  # "go"
        for s in subs:
            s.reset()
        print("counting", flush=True)
        line = await loop.run_in_executor(None, sys.stdin.readline)  # "sent S"
        expected = int(line.split()[1]) * n
        last, changed = -1, time.monotonic()
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            total = sum(s.count for s in subs)
            if total >= expected:
                break
            if total != last:
                last, changed = total, time.monotonic()
            elif time.monotonic() - changed > STALL:
                break
            await asyncio.sleep(0.01)
        last_rx = max(s.last_rx for s in subs)  # perf_counter: same clock in every process
        print(f"count {sum(s.count for s in subs)} {last_rx:.6f}", flush=True)
        await close_all(subs)

    asyncio.run(main())


class Clients:
    """The client processes of one run, driven over their stdin/stdout."""

    def __init__(self, port: int, total: int, procs: int):
        self.port = port
        shares = [total // procs + (1 if i < total % procs else 0) for i in range(procs)]
        self.shares = [s for s in shares if s]
        self.procs: list[asyncio.subprocess.Process] = []

    async def start(self) -> None:
        for n in self.shares:
            self.procs.append(await asyncio.create_subprocess_exec(
                sys.executable, str(Path(__file__).resolve()), "--client", str(self.port),
                str(n), stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE))

    async def expect(self, word: str, timeout: float) -> list[str]:
        async def one(p: asyncio.subprocess.Process) -> str:
            while line := (await p.stdout.readline()).decode():
                if line.startswith(word):
                    return line.strip()
            raise RuntimeError(f"a client process ended before '{word}'")

        return await asyncio.wait_for(asyncio.gather(*(one(p) for p in self.procs)), timeout)

    def tell(self, line: str) -> None:
        for p in self.procs:
            p.stdin.write(line.encode() + b"\n")

    async def stop(self) -> None:
        for p in self.procs:
            if p.returncode is None:
                p.kill()
            await p.wait()


# ======================================================================= one run
async def fanout(port: int, pids: list[int], cfg) -> dict:
    src = ScanSource(TOPIC)
    clients = Clients(port, cfg.clients, cfg.client_procs)
    pub = await RawWs.open(port)
    try:
        pub.send({"op": "advertise", "topic": TOPIC, "type": "sensor_msgs/LaserScan"})
        await clients.start()
        await clients.expect("subscribed", 120)
        warm = asyncio.ensure_future(clients.expect("warm", 90))
        k = 0
        deadline = time.monotonic() + 90
        while not warm.done() and time.monotonic() < deadline:  # until every subscriber has one
            pub.write_frame(ws_frame(src.frame(k)))
            k += 1
            await asyncio.sleep(0.05)
        await warm
        if cfg.ceiling:
            await asyncio.sleep(0.5)
        else:
            await barrier(pub, "warm")
        clients.tell("go")
        await clients.expect("counting", 30)
        cpu0 = cpu_seconds(pids)
        t0 = time.perf_counter()
        sent = 0
        while sent < cfg.count and time.perf_counter() < t0 + cfg.seconds:
            pub.write_frame(ws_frame(src.frame(sent)))
            sent += 1
            await pub.drain()
        clients.tell(f"sent {sent}")
        counts = await clients.expect("count", cfg.seconds + 180)
        cpu = cpu_seconds(pids) - cpu0
        total = sum(int(c.split()[1]) for c in counts)
        elapsed = max(float(c.split()[2]) for c in counts) - t0
        rss = max(rss_mb(p) for p in pids[1:] or pids)
        return {"sent": sent, "total": total, "expected": sent * cfg.clients,
                "elapsed": elapsed, "rate": total / elapsed if elapsed > 0 else float("nan"),
                "cpu": 100 * cpu / elapsed if elapsed > 0 else float("nan"), "rss": rss}
    finally:
        await clients.stop()
        await close_all([pub])


async def run(cfg) -> None:
    cores = os.cpu_count() or 1
    print(f"LaserScan (720 ranges) to {cfg.clients} subscribers over {cfg.client_procs} client "
          f"processes, {cfg.count} messages published as fast as taken; {cores} cores; the "
          "clients and the publisher share the machine with the server")
    rows: list[tuple[str, dict]] = []
    bare = start_ceiling()
    try:
        cfg.ceiling = True
        rows.append(("bare websockets server", await fanout(bare.port, [bare.proc.pid], cfg)))
    finally:
        bare.stop()
    cfg.ceiling = False
    for n in cfg.workers_list:
        server = start_workers(n)
        try:
            pids = tree(server.proc.pid)
            rows.append((f"--workers {n}", await fanout(server.port, pids, cfg)))
        finally:
            server.stop()
    base = next((r["rate"] for name, r in rows if name == f"--workers {cfg.workers_list[0]}"),
                float("nan"))
    ceiling = rows[0][1]["rate"]
    print(table(
        ["server", "sent", "delivered", "of", "seconds", "msg/s", "÷ first", "÷ bare",
         "server CPU", "max RSS MB"],
        [[name, r["sent"], r["total"], r["expected"], fnum(r["elapsed"], 2), fnum(r["rate"]),
          fnum(r["rate"] / base, 2) if name.startswith("--") else "",
          fnum(r["rate"] / ceiling, 2), f"{fnum(r['cpu'])}%", fnum(r["rss"], 1)]
         for name, r in rows],
    ))
    print("  ÷ first: against the first --workers run; server CPU: every process of the "
          "server (parent + workers), 100% = one core; max RSS: the largest worker")


def main() -> int:
    if len(sys.argv) == 4 and sys.argv[1] == "--client":
        client_main(int(sys.argv[2]), int(sys.argv[3]))
        return 0
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    cores = os.cpu_count() or 1
    default = ",".join(str(2**i) for i in range(8) if 2**i <= min(cores, 8))
    parser.add_argument("--quick", action="store_true", help="fewer messages")
    parser.add_argument("--workers-list", default=default,
                        help=f"comma-separated worker counts (default: {default})")
    parser.add_argument("--clients", type=int, default=400, help="subscribers (default 400)")
    parser.add_argument("--client-procs", type=int, default=4,
                        help="client processes the subscribers are spread over (default 4)")
    args = parser.parse_args()
    cfg = argparse.Namespace(
        workers_list=[int(w) for w in args.workers_list.split(",") if w.strip()],
        clients=args.clients, client_procs=args.client_procs,
        count=300 if args.quick else 1500, seconds=15 if args.quick else 40, ceiling=False,
    )
    asyncio.run(run(cfg))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Issue 22's scenario: a slow link subscribed to a big stream and a small topic.

A client that reads 2 MB/s (a weak Wi-Fi link: its socket is read at that pace) subscribes to a
10 MB/s stream (500 kB ``std_msgs/String`` messages at 20 Hz, like a map in mapping mode or a
point cloud) and to a 50 Hz small topic (a pose). A second, fast client subscribes to both and
reads as fast as it can. Prints, per run, how many small messages each client got and how old
they were on arrival, and what the big stream delivered.
No assertions.

The slow reader runs twice: with a 32 kB receive buffer, and with the operating system's
default buffers (autotuned up to megabytes, as a browser's are). With deep buffers only the
server's window of bytes in flight (``--send-window``, transport/flight.py) keeps the pose from
waiting behind what the kernel already holds; every run is made with and without it, the two
servers interleaved.

    .venv/bin/python bench/bench_fair.py            # 10 s per run
    .venv/bin/python bench/bench_fair.py --quick    # 4 s per run
    .venv/bin/python bench/bench_fair.py --buffers default

The big stream is subscribed once with ``fragment_size`` 16000 (the scheduler interleaves the
fragments with the pose) and once without (each 500 kB message is one frame: the pose waits at
most one message, 250 ms at 2 MB/s). Server in its own process on 127.0.0.1.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import socket
import sys
import time
from pathlib import Path

from websockets.asyncio.client import connect

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchlib import HOST, pct, start_ours, table  # noqa: E402

BIG, SMALL = "/bench/cloud", "/bench/pose"
BIG_BYTES = 500_000
BIG_HZ, SMALL_HZ = 20, 50
LINK = 2_000_000  # bytes/s the slow reader takes
WARM_UP = 3.0
"""Seconds of traffic before the measured run: the server's first big messages start its
worker pool, and the send window holds a client only once it has shown a standing queue (and
then drains what the kernel took before). The warm-up's worst age is printed on its own."""


async def slow_client(port: int, rcvbuf: int | None):
    """A link of LINK bytes/s: after each chunk read from the socket, reading pauses for as
    long as the link takes to carry it (the application reads what arrived at once).
    ``rcvbuf``: the socket's receive buffer, or None for the system's default."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if rcvbuf is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    sock.connect((HOST, port))
    sock.setblocking(False)
    ws = await connect(f"ws://{HOST}:{port}", sock=sock, max_size=None, max_queue=None)
    loop = asyncio.get_running_loop()
    received = ws.data_received

    def paced(data: bytes) -> None:
        received(data)
        ws.transport.pause_reading()
        loop.call_later(len(data) / LINK, ws.transport.resume_reading)

    ws.data_received = paced
    return ws


async def ready(ws) -> None:
    await ws.send(json.dumps({"op": "call_service", "id": "ready",
                              "service": "/rosapi/get_time"}))
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        if '"ready"' in await asyncio.wait_for(ws.recv(), 10):
            return
    raise RuntimeError("no answer from the server")


async def run(port: int, seconds: float, fragment_size: int | None,
              rcvbuf: int | None) -> dict:
    slow = await slow_client(port, rcvbuf)
    fast = await connect(f"ws://{HOST}:{port}", max_size=None)
    pub = await connect(f"ws://{HOST}:{port}", max_size=None)
    for topic, mtype in ((BIG, "std_msgs/String"), (SMALL, "std_msgs/String")):
        await pub.send(json.dumps({"op": "advertise", "topic": topic, "type": mtype}))
    for ws in (slow, fast):
        sub = {"op": "subscribe", "topic": BIG, "type": "std_msgs/String"}
        if fragment_size and ws is slow:
            sub["fragment_size"] = fragment_size
        await ws.send(json.dumps(sub))
        await ws.send(json.dumps({"op": "subscribe", "topic": SMALL, "type": "std_msgs/String"}))
        await ready(ws)
    await ready(pub)
    stats = {name: {"small": [], "warm": [], "big": 0, "big_bytes": 0}
             for name in ("slow", "fast")}
    done = asyncio.Event()
    measured_from = [float("inf")]  # poses stamped before are the warm-up's

    async def read(name: str, ws) -> None:
        got = stats[name]
        while not done.is_set():
            try:
                frame = await asyncio.wait_for(ws.recv(), 0.5)
            except TimeoutError:
                continue
            now = time.monotonic()
            if frame.startswith('{"op":"fragment"') or frame.startswith('{"op": "fragment"'):
                msg = json.loads(frame)
                got["big_bytes"] += len(frame)
                got["big"] += msg["num"] == msg["total"] - 1
            elif SMALL in frame[:60]:
                stamp = float(json.loads(frame)["msg"]["data"])
                got["small" if stamp >= measured_from[0] else "warm"].append(now - stamp)
            elif BIG in frame[:60]:
                got["big"] += 1
                got["big_bytes"] += len(frame)

    readers = [asyncio.create_task(read("slow", slow)), asyncio.create_task(read("fast", fast))]
    body = "m" * BIG_BYTES

    async def publish_for(seconds: float) -> tuple[int, int, float]:
        start = time.monotonic()
        ticks = int(seconds * SMALL_HZ)
        big_sent = 0
        for i in range(ticks):
            await pub.send(json.dumps({"op": "publish", "topic": SMALL,
                                       "msg": {"data": repr(time.monotonic())}}))
            if i * BIG_HZ // SMALL_HZ != (i + 1) * BIG_HZ // SMALL_HZ:
                await pub.send(json.dumps({"op": "publish", "topic": BIG,
                                           "msg": {"data": body}}))
                big_sent += 1
            delay = start + (i + 1) / SMALL_HZ - time.monotonic()
            if delay > 0:
                await asyncio.sleep(delay)
        return ticks, big_sent, time.monotonic() - start

    await publish_for(WARM_UP)
    measured_from[0] = time.monotonic()
    for got in stats.values():
        got.update(big=0, big_bytes=0)
    ticks, big_sent, elapsed = await publish_for(seconds)
    await asyncio.sleep(1.0)  # let what is in flight arrive (a bench, not a test)
    done.set()
    await asyncio.gather(*readers)
    for ws in (slow, fast, pub):
        await ws.close()
    return {"ticks": ticks, "big_sent": big_sent, "elapsed": elapsed, **stats}


def report(title: str, r: dict) -> None:
    rows = []
    for name in ("slow", "fast"):
        got = r[name]
        ages = sorted(got["small"])
        rows.append([
            name, f"{len(ages)}/{r['ticks']}", f"{100 * len(ages) / r['ticks']:.1f}%",
            f"{1000 * pct(ages, 50):.0f}" if ages else "-",
            f"{1000 * pct(ages, 99):.0f}" if ages else "-",
            f"{got['big']}/{r['big_sent']}", f"{got['big_bytes'] / r['elapsed'] / 1e6:.2f}",
            f"{1000 * max(got['warm']):.0f}" if got["warm"] else "-",
        ])
    print(f"\n{title}")
    print(table(["client", "small got", "delivered", "age p50 ms", "age p99 ms",
                 "big got", "big MB/s", "warm-up worst ms"], rows))


BUFFERS = {"32k": 32 * 1024, "default": None}


VARIANTS = {"--send-window": ["--send-window"], "--no-send-window": ["--no-send-window"]}
"""The server's send window on and off; each case runs on both, interleaved."""


async def main_async(seconds: float, buffers: list[str]) -> None:
    servers = {name: start_ours(None, "fair", flags) for name, flags in VARIANTS.items()}
    summary = []
    try:
        for buf in buffers:
            for frag in (16_000, None):
                for name, server in servers.items():
                    r = await run(server.port, seconds, frag, BUFFERS[buf])
                    report(f"{name}: slow reader {LINK / 1e6:g} MB/s, receive buffer {buf}; "
                           f"big {BIG_BYTES // 1000} kB x {BIG_HZ} Hz (fragment_size "
                           f"{frag or 'none'}), small x {SMALL_HZ} Hz, {seconds:g} s", r)
                    ages = sorted(r["slow"]["small"])
                    summary.append([
                        name, buf, frag or "none",
                        f"{100 * len(ages) / r['ticks']:.1f}%",
                        f"{1000 * pct(ages, 50):.0f}" if ages else "-",
                        f"{1000 * pct(ages, 99):.0f}" if ages else "-",
                        f"{r['fast']['big_bytes'] / r['elapsed'] / 1e6:.2f}",
                        f"{1000 * max(r['slow']['warm']):.0f}" if r["slow"]["warm"] else "-"])
    finally:
        for server in servers.values():
            server.stop()
    print(f"\nsummary: the slow reader's small topic (age on arrival, after {WARM_UP:g} s of "
          "warm-up) and the fast reader's big MB/s")
    print(table(["server", "receive buffer", "fragment_size", "slow delivered", "age p50 ms",
                 "age p99 ms", "fast big MB/s", "slow warm-up worst ms"], summary))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="4 s per run instead of 10")
    parser.add_argument("--buffers", choices=("both", *BUFFERS), default="both",
                        help="the slow reader's receive buffer (default: both, in turn)")
    args = parser.parse_args()
    buffers = list(BUFFERS) if args.buffers == "both" else [args.buffers]
    asyncio.run(main_async(4.0 if args.quick else 10.0, buffers))
    return 0


if __name__ == "__main__":
    sys.exit(main())

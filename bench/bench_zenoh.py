#!/usr/bin/env python3
"""Scale-out benchmark: one server against two servers joined by Zenoh (``--bus zenoh``).

Prints figures only (no assertions). Loopback only, ephemeral ports, every loop bounded in count
and time; servers run as separate processes with ``--robot none``.

    .venv/bin/python bench/bench_zenoh.py            # about 1.5 minutes on 2 cores
    .venv/bin/python bench/bench_zenoh.py --quick    # about 30 s
    .venv/bin/python bench/bench_zenoh.py --quick --link unixsock   # as --workers joins them

Sections:
  1. fan-out   LaserScan (720 ranges) published as fast as taken, to 200 clients on one server,
               then to 100 + 100 clients on two servers joined by Zenoh (the publisher on A):
               what the second process (and core) buys.
  2. latency   one std_msgs/String at a time from a client on A to a subscriber on the same
               server and to one on B: the hop's added latency, p50/p99.
  3. relay     std_msgs/String as fast as possible from a client on A to one subscriber on B.
"""

from __future__ import annotations

import argparse
import asyncio
import socket
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from benchlib import (  # noqa: E402  (a sibling script, not a package)
    ScanSource,
    ServerProc,
    fnum,
    pct,
    table,
)
from wsclient import HOST, RawWs, barrier, close_all, ws_frame  # noqa: E402

perf = time.perf_counter


def free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


def start(*extra: str) -> ServerProc:
    argv = [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "0",
            "--address", HOST, "--log-level", "warning", "--robot", "none", *extra]
    return ServerProc(argv, r"ws://[\d.]+:(\d+)", "hitrobot-server")


LINK = ["tcp"]  # --link: how A and B are joined


def start_pair() -> tuple[ServerProc, ServerProc]:
    if LINK[0] == "unixsock":  # as the workers of --workers are joined
        endpoint = f"unixsock-stream/{tempfile.mkdtemp(prefix='bench-zenoh-')}/a.sock"
    else:
        endpoint = f"tcp/{HOST}:{free_port()}"
    a = start("--bus", "zenoh", "--zenoh-listen", endpoint)
    b = start("--bus", "zenoh", "--zenoh-connect", endpoint)
    return a, b


async def open_many(port: int, n: int) -> list[RawWs]:
    subs: list[RawWs] = []
    for k in range(0, n, 25):
        subs += await asyncio.gather(*(RawWs.open(port) for _ in range(min(25, n - k))))
    return subs


# ======================================================================= 1. fan-out
async def fanout(pub_port: int, sub_ports: list[tuple[int, int]], servers, cfg) -> dict:
    topic = "/bench/scan"
    src = ScanSource(topic)
    subs: list[RawWs] = []
    for port, n in sub_ports:
        subs += await open_many(port, n)
    pub = await RawWs.open(pub_port)
    pub.send({"op": "advertise", "topic": topic, "type": "sensor_msgs/LaserScan"})
    for s in subs:
        s.send({"op": "subscribe", "topic": topic, "type": "sensor_msgs/LaserScan"})
    deadline = perf() + 20  # warm up until every subscriber (also those across Zenoh) gets one
    k = 0
    while perf() < deadline and min(s.count for s in subs) == 0:
        pub.write_frame(ws_frame(src.frame(k)))
        k += 1
        await asyncio.sleep(0.05)
    await barrier(pub, "warm")
    await asyncio.sleep(0.5)
    for s in subs:
        s.reset()
    cpu0 = [srv.cpu() for srv in servers]
    t0 = perf()
    sent = 0
    while sent < cfg.fanout_count and perf() < t0 + cfg.fanout_seconds:
        pub.write_frame(ws_frame(src.frame(sent)))
        sent += 1
        await pub.drain()
    expected = sent * len(subs)
    last, changed = -1, perf()
    while perf() < t0 + cfg.fanout_seconds + 30:
        total = sum(s.count for s in subs)
        if total >= expected:
            break
        if total != last:
            last, changed = total, perf()
        elif perf() - changed > 2.0:
            break  # no progress for 2 s: the rest was dropped (slow-client policy)
        await asyncio.sleep(0.01)
    elapsed = max(s.last_rx for s in subs) - t0
    cpu = [srv.cpu() - c for srv, c in zip(servers, cpu0, strict=True)]
    total = sum(s.count for s in subs)
    await close_all([pub, *subs])
    return {
        "sent": sent, "clients": len(subs), "total": total, "expected": expected,
        "elapsed": elapsed, "rate": total / elapsed if elapsed > 0 else float("nan"),
        "cpu": " + ".join(f"{100 * c / elapsed:.0f}%" for c in cpu),
    }


# ======================================================================= 2. latency
async def latency(pub_port: int, sub_port: int, samples: int) -> list[float]:
    topic = f"/bench/ping{sub_port}"
    got: asyncio.Queue[float] = asyncio.Queue()
    sub = await RawWs.open(sub_port, on_message=lambda _p, now: got.put_nowait(now))
    pub = await RawWs.open(pub_port)
    pub.send({"op": "advertise", "topic": topic, "type": "std_msgs/String"})
    sub.send({"op": "subscribe", "topic": topic, "type": "std_msgs/String"})
    frame = ws_frame(b'{"op":"publish","topic":"' + topic.encode() + b'","msg":{"data":"p"}}')
    deadline = perf() + 20
    while perf() < deadline and got.empty():  # until the subscription has crossed
        pub.write_frame(frame)
        await asyncio.sleep(0.05)
    await asyncio.sleep(0.3)
    while not got.empty():
        got.get_nowait()
    out: list[float] = []
    stop = perf() + 60
    while len(out) < samples and perf() < stop:
        t = perf()
        pub.write_frame(frame)
        try:
            out.append(await asyncio.wait_for(got.get(), 5) - t)
        except TimeoutError:
            break
    await close_all([pub, sub])
    return out


# ======================================================================= 3. relay
async def relay(pub_port: int, sub_port: int, cfg) -> dict:
    topic = f"/bench/relay{sub_port}"
    sub = await RawWs.open(sub_port)
    pub = await RawWs.open(pub_port)
    pub.send({"op": "advertise", "topic": topic, "type": "std_msgs/String"})
    sub.send({"op": "subscribe", "topic": topic, "type": "std_msgs/String"})
    frame = ws_frame(b'{"op":"publish","topic":"' + topic.encode() + b'","msg":{"data":"r"}}')
    deadline = perf() + 20
    while perf() < deadline and sub.count == 0:
        pub.write_frame(frame)
        await asyncio.sleep(0.05)
    await asyncio.sleep(0.3)
    sub.reset()
    t0 = perf()
    sent = 0
    while sent < cfg.relay_count and perf() < t0 + cfg.relay_seconds:
        window = sent - sub.count  # bounded in flight, so nothing is dropped for slowness
        if window > 2000:
            await asyncio.sleep(0.001)
            continue
        for _ in range(100):
            pub.write_frame(frame)
        sent += 100
        await pub.drain()
    end = perf() + 10
    while sub.count < sent and perf() < end:
        await asyncio.sleep(0.01)
    elapsed = sub.last_rx - t0
    await close_all([pub, sub])
    return {"sent": sent, "got": sub.count, "rate": sub.count / elapsed if elapsed > 0 else 0}


# ======================================================================= main
def config(quick: bool) -> argparse.Namespace:
    return argparse.Namespace(
        fanout_count=500 if quick else 3000,
        fanout_seconds=15 if quick else 40,
        latency_samples=200 if quick else 1000,
        relay_count=20_000 if quick else 100_000,
        relay_seconds=5 if quick else 15,
    )


async def run(cfg) -> None:
    print("1. LaserScan fan-out to 200 clients (as fast as the servers take it)")
    rows = []
    one = start()
    try:
        rows.append(["one server", await fanout(one.port, [(one.port, 200)], [one], cfg)])
    finally:
        one.stop()
    a, b = start_pair()
    try:
        split = await fanout(a.port, [(a.port, 100), (b.port, 100)], [a, b], cfg)
        rows.append(["A + B over Zenoh", split])
    finally:
        b.stop()
        a.stop()
    print(table(
        ["setup", "sent", "delivered", "of", "seconds", "msgs/s delivered", "server CPU"],
        [[name, r["sent"], r["total"], r["expected"], fnum(r["elapsed"], 2), fnum(r["rate"]),
          r["cpu"]] for name, r in rows],
    ))

    a, b = start_pair()
    try:
        print("\n2. latency of one std_msgs/String, client on A to a subscriber")
        same = await latency(a.port, a.port, cfg.latency_samples)
        cross = await latency(a.port, b.port, cfg.latency_samples)
        rows = [["on A (same server)", same], ["on B (via Zenoh)", cross]]
        print(table(
            ["subscriber", "samples", "p50 ms", "p99 ms"],
            [[n, len(v), fnum(pct(v, 50) * 1e3, 3), fnum(pct(v, 99) * 1e3, 3)] for n, v in rows],
        ))
        print(f"  added by the hop: p50 {fnum((pct(cross, 50) - pct(same, 50)) * 1e3, 3)} ms, "
              f"p99 {fnum((pct(cross, 99) - pct(same, 99)) * 1e3, 3)} ms")

        print("\n3. relay rate of std_msgs/String, client on A to one subscriber")
        rows = [["on A (same server)", await relay(a.port, a.port, cfg)],
                ["on B (via Zenoh)", await relay(a.port, b.port, cfg)]]
        print(table(["subscriber", "sent", "received", "msgs/s"],
                    [[n, r["sent"], r["got"], fnum(r["rate"])] for n, r in rows]))
    finally:
        b.stop()
        a.stop()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs")
    parser.add_argument("--link", choices=("tcp", "unixsock"), default="tcp",
                        help="join A and B over loopback TCP (default) or a Unix socket")
    args = parser.parse_args()
    LINK[0] = args.link
    asyncio.run(run(config(args.quick)))
    return 0


if __name__ == "__main__":
    sys.exit(main())

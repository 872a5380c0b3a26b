#!/usr/bin/env python3
"""Memory: the server's RSS with 1000 idle WebSocket clients, and while one subscriber stops
reading LaserScans for 30 s (10 s with --quick) next to one that reads.

RSS is VmRSS of the server and its worker processes. Prints figures only; the server runs in
its own process.

    .venv/bin/python bench/bench_memory.py --quick
"""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchlib import (  # noqa: E402  (a sibling script, not a package)
    Config,
    ScanSource,
    parser,
    run_main,
    start_ours,
    table,
)
from wsclient import RawWs, barrier, close_all, perf, ws_frame  # noqa: E402


async def idle_rss(cfg: Config) -> dict:
    server = start_ours(None, "idle")
    clients: list[RawWs] = []
    try:
        probe = await RawWs.open(server.port)
        await barrier(probe, "idle-empty")
        await asyncio.sleep(0.5)
        empty = server.rss_now_mb()
        for start in range(0, cfg.idle_clients, 100):
            batch = min(100, cfg.idle_clients - start)
            clients += await asyncio.gather(*(RawWs.open(server.port) for _ in range(batch)))
        await barrier(probe, "idle-full", timeout=30)
        await asyncio.sleep(0.5)
        full = server.rss_now_mb()
    finally:
        await close_all(clients)
        server.stop()
    return {"clients": len(clients), "empty": empty, "full": full}


async def stalled_rss(cfg: Config) -> dict:
    """One subscriber stops reading while LaserScans flow to it and to a normal subscriber."""
    server = start_ours(None, "stalled")
    topic = "/bench/stalled"
    src = ScanSource(topic)
    try:
        pub = await RawWs.open(server.port)
        good = await RawWs.open(server.port)
        stuck = await RawWs.open(server.port)
        pub.send({"op": "advertise", "topic": topic, "type": "sensor_msgs/LaserScan"})
        for c in (good, stuck):
            c.send({"op": "subscribe", "topic": topic, "type": "sensor_msgs/LaserScan"})
        for c in (pub, good, stuck):
            await barrier(c, "stalled")
        stuck.transport.pause_reading()  # the kernel buffers fill, then the server's outbox
        rss = [server.rss_now_mb()]
        sent = 0
        t0 = perf()
        next_sample = t0 + 1
        while perf() - t0 < cfg.stall_seconds:
            for _ in range(cfg.stall_rate // 100):
                pub.write_frame(ws_frame(src.frame(sent)))
                sent += 1
            await pub.drain()
            await asyncio.sleep(0.01)
            if perf() >= next_sample:
                rss.append(server.rss_now_mb())
                next_sample += 1
        await barrier(good, "stalled-end", timeout=30)
        elapsed = perf() - t0
        rss.append(server.rss_now_mb())
        result = {
            "seconds": elapsed,
            "sent": sent,
            "good": good.count,
            "rss": rss,
            "mb": sent * len(src.frame(0)) / 1e6,
        }
        stuck.transport.abort()
        await close_all([pub, good])
    finally:
        server.stop()
    return result


async def memory_section(cfg: Config) -> dict:
    idle = await idle_rss(cfg)
    stall = await stalled_rss(cfg)
    per_client = 1024 * (idle["full"] - idle["empty"]) / max(idle["clients"], 1)
    print(
        "\n[6] memory: server RSS (VmRSS, worker processes included) with idle clients, and "
        "with a subscriber that stops reading"
    )
    print(
        table(
            ["run", "RSS before MB", "RSS after MB", "delta MB", "detail"],
            [
                [
                    f"{idle['clients']} idle WebSocket clients",
                    f"{idle['empty']:.1f}",
                    f"{idle['full']:.1f}",
                    f"{idle['full'] - idle['empty']:.1f}",
                    f"{per_client:.1f} kB/client",
                ],
                [
                    f"stalled reader, {stall['seconds']:.0f} s",
                    f"{stall['rss'][0]:.1f}",
                    f"{stall['rss'][-1]:.1f}",
                    f"{stall['rss'][-1] - stall['rss'][0]:.1f}",
                    f"max {max(stall['rss']):.1f} MB; {stall['sent']:,} scans "
                    f"({stall['mb']:.0f} MB) sent, the reading subscriber got {stall['good']:,}",
                ],
            ],
        )
    )
    samples = " ".join(f"{x:.0f}" for x in stall["rss"])
    print(
        f"  stalled: LaserScans at ~{cfg.stall_rate}/s to a reading and a non-reading "
        f"subscriber; RSS sampled every second: {samples}"
    )
    return {"idle": idle, "stall": stall}


async def scenario(cfg: Config) -> list[str]:
    """Section [6], each part on a fresh server; returns its summary line."""
    mem = await memory_section(cfg)
    idle, stall = mem["idle"], mem["stall"]
    return [
        f"{idle['clients']} idle clients: +{idle['full'] - idle['empty']:.1f} MB RSS; stalled "
        f"reader over {stall['seconds']:.0f} s: RSS {stall['rss'][0]:.0f} -> max "
        f"{max(stall['rss']):.0f} MB"
    ]


if __name__ == "__main__":
    sys.exit(run_main(parser(__doc__.split("\n\n")[0]).parse_args(), scenario))

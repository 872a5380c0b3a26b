#!/usr/bin/env python3
"""Map: a 2000x2000 nav_msgs/OccupancyGrid on a latched topic, compression none and png.

Publish -> decoded time for a live subscriber and a late joiner, the wire size, and how long a
probe client's ping-pong through the server stalls while one map is handled. The png map is
decoded as roslibjs 2.x does (base64 -> PNG -> RGB bytes -> UTF-8 -> JSON). Prints figures
only; the server runs in its own process.

    .venv/bin/python bench/bench_map.py --quick
"""

from __future__ import annotations

import asyncio
import base64
import io
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import orjson
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchlib import (  # noqa: E402  (a sibling script, not a package)
    Config,
    CpuMeter,
    ServerProc,
    fnum,
    parser,
    pct,
    run_main,
    start_ours,
    table,
)
from wsclient import RawWs, barrier, close_all, perf, ws_frame  # noqa: E402


def make_grid(w: int, h: int) -> dict:
    """A plausible SLAM map: unknown outside an explored ellipse, free inside, walls every
    200 cells with door gaps, 1% scattered obstacles."""
    rng = np.random.default_rng(11)
    yy, xx = np.mgrid[0:h, 0:w]
    grid = np.full((h, w), -1, dtype=np.int8)
    inside = ((xx - w / 2) / (0.45 * w)) ** 2 + ((yy - h / 2) / (0.35 * h)) ** 2 < 1
    grid[inside] = 0
    walls = ((xx % 200 < 2) | (yy % 200 < 2)) & ~((xx % 200 > 80) & (xx % 200 < 120)) & inside
    grid[walls] = 100
    grid[inside & (rng.random((h, w)) < 0.01)] = 100
    return {
        "header": {"seq": 1, "stamp": {"secs": 1_700_000_000, "nsecs": 0}, "frame_id": "map"},
        "info": {
            "map_load_time": {"secs": 1_700_000_000, "nsecs": 0},
            "resolution": 0.05,
            "width": w,
            "height": h,
            "origin": {
                "position": {"x": -50.0, "y": -50.0, "z": 0.0},
                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
            },
        },
        "data": grid.ravel().tolist(),
    }


def decode_map(payload: bytes, compression: str) -> dict:
    """As roslibjs 2.x: png -> base64 -> PNG -> RGB bytes -> UTF-8 -> JSON."""
    op = orjson.loads(payload)
    if compression == "png":
        img = Image.open(io.BytesIO(base64.b64decode(op["data"])))
        img.load()
        op = orjson.loads(img.convert("RGB").tobytes().decode("utf-8"))
    return op


async def map_receive(sub: RawWs, start_fn: Callable[[], None], timeout: float):
    """Run start_fn, then wait for one data frame; returns (t0, t_first_byte, t_frame, payload)."""
    loop = asyncio.get_running_loop()
    got: asyncio.Future = loop.create_future()
    marks = {}

    def on_first(t: float) -> None:
        marks["first"] = t

    def on_msg(payload: bytes, now: float) -> None:
        if payload.startswith(b'{"op":"status"') or b"service_response" in payload[:40]:
            return
        if not got.done():
            got.set_result((payload, perf()))

    sub.on_message = on_msg
    sub.on_first_byte = on_first
    t0 = perf()
    start_fn()
    payload, t_frame = await asyncio.wait_for(got, timeout)
    sub.on_message = None
    sub.on_first_byte = None
    return t0, marks.get("first", t_frame), t_frame, payload


def occupancy_subscribe(topic: str, compression: str) -> dict:
    return {"op": "subscribe", "topic": topic, "type": "nav_msgs/OccupancyGrid",
            "compression": compression}


async def map_once(
    port: int, server: ServerProc, grid: dict, topic: str, compression: str, timeout: float
) -> dict:
    """Publish ``grid`` on a fresh latched topic to a subscriber already there (live), then
    subscribe a second client (late: gets the latched copy); times both up to decoded JSON."""
    data = grid["data"]
    pub_frame = ws_frame(orjson.dumps({"op": "publish", "topic": topic, "msg": grid}))
    pub = await RawWs.open(port)
    live = await RawWs.open(port)
    pub.send({"op": "advertise", "topic": topic, "type": "nav_msgs/OccupancyGrid", "latch": True})
    live.send(occupancy_subscribe(topic, compression))
    await barrier(pub, "map-pub")
    await barrier(live, "map-sub")
    with CpuMeter(server) as cpu:
        t0, t_first, t_frame, payload = await map_receive(
            live, lambda: pub.write_frame(pub_frame), timeout
        )
        msg = decode_map(payload, compression)
        t_dec = perf()
    ok = msg["op"] == "publish" and msg["msg"]["data"] == data
    late = await RawWs.open(port)
    sub_op = orjson.dumps(occupancy_subscribe(topic, compression))
    lt0, _, lt_frame, lpayload = await map_receive(late, lambda: late.send(sub_op), timeout)
    lmsg = decode_map(lpayload, compression)
    lt_dec = perf()
    ok = ok and lmsg["msg"]["data"] == data
    await close_all([pub, live, late])
    return {
        "compression": compression,
        "up": len(pub_frame),
        "wire": len(payload),
        "first": (t_first - t0) * 1e3,
        "frame": (t_frame - t0) * 1e3,
        "decode": (t_dec - t_frame) * 1e3,
        "total": (t_dec - t0) * 1e3,
        "late_frame": (lt_frame - lt0) * 1e3,
        "late_total": (lt_dec - lt0) * 1e3,
        "ok": ok,
        "cpu": cpu.server_s,
    }


class Prober:
    """A client that ping-pongs small messages through the server, one in flight, and keeps
    (send time, round trip) of each."""

    def __init__(self) -> None:
        self.pending: dict[int, asyncio.Future] = {}
        self.rtts: list[tuple[float, float]] = []
        self.done = asyncio.Event()

    async def open(self, port: int) -> RawWs:
        self.client = await RawWs.open(port, on_message=self.on_message)
        self.client.send({"op": "advertise", "topic": "/bench/probe", "type": "std_msgs/String"})
        self.client.send({"op": "subscribe", "topic": "/bench/probe", "type": "std_msgs/String"})
        return self.client

    def on_message(self, payload: bytes, now: float) -> None:
        i = payload.find(b'"data":"')
        if i >= 0:
            fut = self.pending.pop(int(payload[i + 8 : payload.find(b'"', i + 8)]), None)
            if fut is not None and not fut.done():
                fut.set_result(now)

    async def run(self, timeout: float) -> None:
        """Until ``done`` is set (or ``timeout`` s)."""
        loop = asyncio.get_running_loop()
        seq = 0
        end = perf() + timeout
        while not self.done.is_set() and perf() < end:
            seq += 1
            fut = self.pending[seq] = loop.create_future()
            start = perf()
            self.client.send(b'{"op":"publish","topic":"/bench/probe","msg":{"data":"%d"}}' % seq)
            try:
                self.rtts.append((start, await asyncio.wait_for(fut, 10) - start))
            except TimeoutError:
                self.pending.pop(seq, None)
            await asyncio.sleep(0.001)


async def map_stall(port: int, grid: dict, compression: str, timeout: float) -> dict:
    """How long the server stops serving other clients while it handles one big map: a probe
    client ping-pongs small messages through the server (1 in flight) while the map is
    published to a subscriber that only counts frames (no client-side decoding here, so this
    process's event loop stays free and the probe RTTs are the server's)."""
    topic = f"/bench/map_stall_{compression}"
    pub_frame = ws_frame(orjson.dumps({"op": "publish", "topic": topic, "msg": grid}))
    prober = Prober()
    pub = await RawWs.open(port)
    sub = await RawWs.open(port)
    probe = await prober.open(port)
    pub.send({"op": "advertise", "topic": topic, "type": "nav_msgs/OccupancyGrid", "latch": True})
    sub.send(occupancy_subscribe(topic, compression))
    for c in (pub, sub, probe):
        await barrier(c, "stall")
    sub.reset()
    task = asyncio.create_task(prober.run(timeout))
    await asyncio.sleep(0.3)
    t0 = perf()
    pub.write_frame(pub_frame)
    end = t0 + timeout
    while sub.count == 0 and perf() < end:
        await asyncio.sleep(0.002)
    await asyncio.sleep(0.2)
    prober.done.set()
    await task
    await close_all([pub, sub, probe])
    before = [r for t, r in prober.rtts if t < t0]
    during = [r for t, r in prober.rtts if t >= t0 - 0.05]
    return {
        "base": pct(before, 50) * 1e3,
        "max": max(during, default=float("nan")) * 1e3,
        "n": len(prober.rtts),
    }


async def map_runs(server: ServerProc, grid: dict, cfg: Config) -> tuple[list[dict], dict]:
    """One untimed warm-up per compression (first-touch memory costs), ``cfg.map_reps`` timed
    runs of each, then the stall of each: (runs, stalls by compression)."""
    results = []
    for compression in ("none", "png"):
        await map_once(server.port, server, grid, f"/bench/map_warm_{compression}",
                       compression, cfg.map_timeout)
    for compression in ("none", "png"):
        for rep in range(cfg.map_reps):
            r = await map_once(server.port, server, grid, f"/bench/map_{compression}_{rep}",
                               compression, cfg.map_timeout)
            r["rep"] = rep
            results.append(r)
    stalls = {c: await map_stall(server.port, grid, c, cfg.map_timeout) for c in ("none", "png")}
    return results, stalls


def print_maps(size: int, results: list[dict], stalls: dict, rss: float) -> None:
    print(
        f"\n[3] map: {size}x{size} nav_msgs/OccupancyGrid, latched, published by a client "
        f"(publish frame {results[0]['up'] / 1e6:.1f} MB)"
    )
    rows = [
        [r["compression"], r["rep"] + 1, f"{r['wire'] / 1e6:.2f}", fnum(r["first"], 1),
         fnum(r["frame"], 1), fnum(r["decode"], 1), fnum(r["total"], 1), f"{r['cpu']:.2f}",
         fnum(r["late_frame"], 1), fnum(r["late_total"], 1), "yes" if r["ok"] else "NO"]
        for r in results
    ]
    print(table(["compression", "run", "wire MB", "1st byte ms", "frame ms", "decode ms",
                 "publish->decoded ms", "srv CPU s", "late: frame ms", "late: decoded ms",
                 "data ok"], rows))
    print(
        "  times from the client's publish (t=0); one untimed warm-up per compression first."
        "\n  live = subscribed before the publish; late = subscribes afterwards and gets the "
        "latched copy (t=0: its subscribe).\n  1st byte = upload of the publish frame + "
        "server parse, convert, encode; decode = client side (orjson; png: base64 -> PIL\n"
        "  -> RGB bytes -> UTF-8 -> JSON, as roslibjs 2.x does). "
        f"Server peak RSS {rss:.0f} MB (worker pool included)."
    )
    print(
        "  other clients during one map publish (a probe client's ping-pong through the "
        "server, 1 in flight):"
    )
    print(
        table(
            ["compression", "probe RTT before, p50 ms", "probe RTT max during, ms"],
            [[c, f"{st['base']:.2f}", fnum(st["max"], 1)] for c, st in stalls.items()],
        )
    )


async def map_section(cfg: Config) -> list[dict]:
    grid = make_grid(cfg.map_size, cfg.map_size)
    server = start_ours(cfg.profile, "map")
    try:
        results, stalls = await map_runs(server, grid, cfg)
        rss = server.rss_mb()
    finally:
        server.stop()
    print_maps(cfg.map_size, results, stalls, rss)
    for r in results:
        r["stall"] = stalls[r["compression"]]["max"]
    return results


async def scenario(cfg: Config) -> list[str]:
    """Section [3] on a fresh server; returns its summary lines."""
    maps = await map_section(cfg)
    lines = []
    for comp in ("none", "png"):
        rs = [r for r in maps if r["compression"] == comp]
        best = min(rs, key=lambda r: r["total"])
        lines.append(
            f"map {cfg.map_size}x{cfg.map_size} {comp:>4}: publish->decoded "
            f"{fnum(best['total'])} ms (best of {len(rs)}), wire "
            f"{best['wire'] / 1e6:.2f} MB, late joiner {fnum(best['late_total'])}"
            f" ms; other clients stalled up to {fnum(best['stall'])} ms"
        )
    return lines


if __name__ == "__main__":
    sys.exit(run_main(parser(__doc__.split("\n\n")[0]).parse_args(), scenario))

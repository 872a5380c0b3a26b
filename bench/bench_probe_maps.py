#!/usr/bin/env python3
"""Probe while maps: a client (its own process) calls /rosapi/get_time every 5 ms while
another publishes 2000x2000 and 4000x4000 OccupancyGrid maps, one after the other, to one png
and one uncompressed subscriber.

Probe round trip p50 before, p50 and max during; publish -> decoded per compression. The
probe client is this file too (``--probe-client PORT``). Prints figures only; the server runs
in its own process.

    .venv/bin/python bench/bench_probe_maps.py --quick
"""

from __future__ import annotations

import asyncio
import subprocess
import sys
import time
from pathlib import Path

import orjson

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_map import decode_map, make_grid, occupancy_subscribe  # noqa: E402
from benchlib import (  # noqa: E402  (a sibling script, not a package)
    ROOT,
    Config,
    fnum,
    parser,
    pct,
    run_main,
    start_ours,
    table,
)
from wsclient import RawWs, barrier, close_all, perf, ws_frame  # noqa: E402


# ======================================================================= the probe process
def probe_client_main(port: int, limit: float) -> None:
    """A separate process (so the bench's own decoding never delays it): calls
    /rosapi/get_time every 5 ms until stdin closes (or ``limit`` s), then prints one JSON line
    of [monotonic send time, RTT s] pairs."""

    async def main() -> None:
        loop = asyncio.get_running_loop()
        pending: dict[bytes, asyncio.Future] = {}

        def on_msg(payload: bytes, now: float) -> None:
            i = payload.find(b'"id":"p')
            if i >= 0:
                fut = pending.pop(payload[i + 6 : payload.find(b'"', i + 6)], None)
                if fut is not None and not fut.done():
                    fut.set_result(time.monotonic())

        client = await RawWs.open(port, on_message=on_msg)
        stop = asyncio.Event()
        loop.add_reader(sys.stdin.fileno(), lambda: stop.set() if not sys.stdin.read(1) else None)
        rtts: list[tuple[float, float]] = []
        end = time.monotonic() + limit
        seq = 0
        print("ready", flush=True)
        while not stop.is_set() and time.monotonic() < end:
            seq += 1
            key = b"p%d" % seq
            fut = pending[key] = loop.create_future()
            start = time.monotonic()
            client.send(b'{"op":"call_service","id":"%s","service":"/rosapi/get_time"}' % key)
            try:
                rtts.append((start, await asyncio.wait_for(fut, 10) - start))
            except TimeoutError:
                pending.pop(key, None)
            await asyncio.sleep(max(0.0, 0.005 - (time.monotonic() - start)))
        await client.close()
        print(orjson.dumps(rtts).decode(), flush=True)

    asyncio.run(main())


# ======================================================================= the maps
class MapPublisher:
    """A publisher of maps and two subscribers, one per compression (none, png)."""

    async def open(self, port: int) -> None:
        self.pub = await RawWs.open(port)
        self.subs = {c: await RawWs.open(port) for c in ("none", "png")}

    async def topic(self, size: int) -> tuple[bytes, list]:
        """A latched topic for ``size``x``size`` maps, subscribed by both: (the publish frame
        of one map, its data)."""
        grid = make_grid(size, size)
        topic = f"/bench/probe_map_{size}"
        self.pub.send(
            {"op": "advertise", "topic": topic, "type": "nav_msgs/OccupancyGrid", "latch": True}
        )
        for comp, sub in self.subs.items():
            sub.send(occupancy_subscribe(topic, comp))
        for c in (self.pub, *self.subs.values()):
            await barrier(c, "probe-maps")
        return ws_frame(orjson.dumps({"op": "publish", "topic": topic, "msg": grid})), grid["data"]

    async def publish_once(self, frame: bytes, timeout: float) -> dict:
        """One map; each subscriber's frame time (ms after the publish) and payload."""
        got = {c: asyncio.get_running_loop().create_future() for c in self.subs}
        for comp, sub in self.subs.items():

            def on_msg(payload, now, comp=comp):
                if payload.startswith(b'{"op":"status"') or b"service_resp" in payload[:40]:
                    return
                if not got[comp].done():
                    got[comp].set_result((payload, now))

            sub.on_message = on_msg
        t0 = perf()
        self.pub.write_frame(frame)
        out = {}
        for comp, fut in got.items():
            payload, t_frame = await asyncio.wait_for(fut, timeout)
            out[comp] = {"frame": (t_frame - t0) * 1e3, "payload": payload}
        for sub in self.subs.values():
            sub.on_message = None
        return out

    async def close(self) -> None:
        await close_all([self.pub, *self.subs.values()])


def decode_runs(runs: list[dict], data: list) -> None:
    """After the probe window, so that this process's decoding (a core's worth on a 2-core
    machine) does not starve the server and the probe during it."""
    for run in runs:
        for comp, r in run.items():
            t = perf()
            msg = decode_map(r.pop("payload"), comp)
            r["decoded"] = r["frame"] + (perf() - t) * 1e3
            r["ok"] = msg["msg"]["data"] == data


async def probe_window(port: int, maps: MapPublisher, frame: bytes, cfg: Config):
    """The probe process runs 0.5 s alone, then during ``cfg.probe_map_reps`` maps:
    (the maps' runs, the probe's [send time, RTT] pairs, the window's start and end)."""
    probe = subprocess.Popen(
        [sys.executable, str(Path(__file__).resolve()), "--probe-client", str(port)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        line = await asyncio.to_thread(probe.stdout.readline)
        if line.strip() != "ready":
            raise RuntimeError(f"probe client did not start: {line!r}")
        await asyncio.sleep(0.5)  # RTTs before the maps
        t0 = time.monotonic()
        runs = [await maps.publish_once(frame, cfg.map_timeout)
                for _ in range(cfg.probe_map_reps)]
        t1 = time.monotonic()
        await asyncio.sleep(0.2)
    finally:
        out, _ = await asyncio.to_thread(probe.communicate, "", 30)
    return runs, orjson.loads(out.strip().splitlines()[-1]), t0, t1


async def probe_size(port: int, maps: MapPublisher, size: int, cfg: Config) -> dict:
    frame, data = await maps.topic(size)
    if size == cfg.probe_map_sizes[0]:
        await maps.publish_once(frame, cfg.map_timeout)  # untimed: starts the worker pool
    runs, rtts, t0, t1 = await probe_window(port, maps, frame, cfg)
    decode_runs(runs, data)
    before = [r for t, r in rtts if t < t0]
    during = [r for t, r in rtts if t0 <= t <= t1]
    return {
        "size": size,
        "frame_mb": len(frame) / 1e6,
        "maps": len(runs),
        "base_p50": pct(before, 50) * 1e3,
        "p50": pct(during, 50) * 1e3,
        "max": max(during, default=float("nan")) * 1e3,
        "n": len(during),
        "none": min(r["none"]["decoded"] for r in runs),
        "png": min(r["png"]["decoded"] for r in runs),
        "png_max": max(r["png"]["decoded"] for r in runs),
        "ok": all(r[c]["ok"] for r in runs for c in maps.subs),
    }


def print_probe(results: list[dict], rss: float) -> None:
    print(
        "\n[5] probe while maps: a client calls /rosapi/get_time every 5 ms (its own process) "
        "while another publishes\n    OccupancyGrid maps on a latched topic to one png and one "
        "uncompressed subscriber, one map after the other"
    )
    rows = [
        [f"{r['size']}x{r['size']}", f"{r['frame_mb']:.1f}", r["maps"], f"{r['base_p50']:.2f}",
         f"{r['p50']:.2f}", fnum(r["max"], 1), r["n"], fnum(r["none"]),
         f"{fnum(r['png'])} (max {fnum(r['png_max'])})", "yes" if r["ok"] else "NO"]
        for r in results
    ]
    print(table(["map", "publish MB", "maps", "probe p50 before ms", "probe p50 during ms",
                 "probe max during ms", "probes", "none: publish->decoded ms",
                 "png: publish->decoded ms", "data ok"], rows))
    print(
        "  publish->decoded: best of the maps = frame received + client decode (timed after the "
        "probe window, so the\n  bench's decoding does not compete with the server for the 2 "
        f"cores during it). Server peak RSS "
        f"{rss:.0f} MB (main process + worker pool peaks; the pool's CPU is not counted)."
    )


async def probe_maps_section(cfg: Config) -> list[dict]:
    """Issue 11's scenario: a client calls /rosapi/get_time every 5 ms while another publishes
    big maps to one png and one uncompressed subscriber; probe RTT before and during."""
    server = start_ours(cfg.profile, "probe_maps")
    try:
        maps = MapPublisher()
        await maps.open(server.port)
        results = [await probe_size(server.port, maps, size, cfg)
                   for size in cfg.probe_map_sizes]
        await maps.close()
        rss = server.rss_mb()
    finally:
        server.stop()
    print_probe(results, rss)
    return results


async def scenario(cfg: Config) -> list[str]:
    """Section [5] on a fresh server; returns its summary lines."""
    return [
        f"probe RTT during {r['size']}x{r['size']} maps: p50 {r['p50']:.2f} ms, max "
        f"{fnum(r['max'], 1)} ms (before: p50 {r['base_p50']:.2f}); png publish->decoded "
        f"{fnum(r['png'])} ms, none {fnum(r['none'])} ms"
        for r in await probe_maps_section(cfg)
    ]


def main() -> int:
    p = parser(__doc__.split("\n\n")[0])
    p.add_argument("--probe-client", type=int, metavar="PORT",
                   help="be the probe client (what the scenario starts in its own process)")
    args = p.parse_args()
    if args.probe_client:
        probe_client_main(args.probe_client, limit=300.0)
        return 0
    return run_main(args, scenario)


if __name__ == "__main__":
    sys.exit(main())

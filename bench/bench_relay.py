#!/usr/bin/env python3
"""Relay: std_msgs/String, 1 publisher -> hitrobot-server -> 1 subscriber, over loopback.

A pipelined run per bounded in-flight window (throughput: msg/s, p50/p99 latency from a send
timestamp carried in the data) and a ping-pong run with one message in flight (latency). Prints
figures only; the server runs in its own process.

    .venv/bin/python bench/bench_relay.py --quick
"""

from __future__ import annotations

import asyncio
import sys
import time
from pathlib import Path

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

TOPIC = "/bench/relay"


class Relay:
    """One publisher and one subscriber of ``TOPIC``; each message's data is
    ``"<seq> <perf_counter_ns at send>"``, so the subscriber times it with the sender's clock."""

    def __init__(self) -> None:
        self.wake = asyncio.Event()
        self.recv = 0
        self.lat: list[float] = []
        self.pending: dict[int, asyncio.Future] = {}
        self.prefix = b'{"op":"publish","topic":"' + TOPIC.encode() + b'","msg":{"data":"'
        self.msg_size = len(self.prefix) + 30

    async def open(self, port: int) -> None:
        self.pub = await RawWs.open(port)
        self.sub = await RawWs.open(port, on_message=self.on_message)
        self.pub.send({"op": "advertise", "topic": TOPIC, "type": "std_msgs/String"})
        self.sub.send({"op": "subscribe", "topic": TOPIC, "type": "std_msgs/String"})
        await barrier(self.pub, "relay-pub")
        await barrier(self.sub, "relay-sub")

    def on_message(self, payload: bytes, now: float) -> None:
        i = payload.find(b'"data":"')
        if i < 0:
            return
        j = payload.find(b'"', i + 8)
        seq_s, ts = payload[i + 8 : j].split(b" ")
        self.recv += 1
        self.lat.append(now - int(ts) / 1e9)
        fut = self.pending.pop(int(seq_s), None)
        if fut is not None and not fut.done():
            fut.set_result(now)
        self.wake.set()

    def frame(self, seq: int) -> bytes:
        return ws_frame(self.prefix + f'{seq} {time.perf_counter_ns()}"}}}}'.encode())

    def reset(self) -> None:
        self.recv, self.lat = 0, []

    async def warm_up(self) -> None:
        """200 messages through (also proves the path works), bounded: 5 s."""
        for k in range(200):
            self.pub.write_frame(self.frame(10_000_000 + k))
        deadline = perf() + 5
        while self.recv < 200 and perf() < deadline:
            await asyncio.sleep(0.01)

    async def _window_free(self, window: int, sent: int, stop_at: float) -> bool:
        """Wait until fewer than ``window`` messages are in flight; False when nothing came
        back for 2 s (stuck)."""
        while sent - self.recv >= window:
            self.wake.clear()
            try:
                await asyncio.wait_for(self.wake.wait(), 2.0)
            except TimeoutError:
                break
            if perf() >= stop_at + 2:
                break
        return sent - self.recv < window

    async def pipelined(self, server: ServerProc, window: int, cfg: Config) -> dict:
        """As fast as the window allows, for ``cfg.relay_count`` messages or seconds."""
        self.reset()
        sent = 0
        with CpuMeter(server) as cpu:
            t0 = perf()
            stop_at = t0 + cfg.relay_seconds
            while sent < cfg.relay_count and perf() < stop_at:
                if not await self._window_free(window, sent, stop_at):
                    break
                self.pub.write_frame(self.frame(sent))
                sent += 1
                if sent % 64 == 0:
                    await self.pub.drain()
            deadline = perf() + 3
            while self.recv < sent and perf() < deadline:
                await asyncio.sleep(0.005)
            elapsed = self.sub.last_rx - t0
        recv = self.recv
        return {
            "sent": sent,
            "recv": recv,
            "elapsed": elapsed,
            "rate": recv / elapsed if elapsed > 0 else float("nan"),
            "p50": pct(self.lat, 50) * 1e3,
            "p99": pct(self.lat, 99) * 1e3,
            "cpu": cpu.pcts(elapsed),
            "srv_us": 1e6 * cpu.server_s / recv if recv else float("nan"),
        }

    async def ping_pong(self, server: ServerProc, cfg: Config) -> dict:
        """One message in flight at a time: the round trip through the server."""
        self.reset()
        rtts = []
        loop = asyncio.get_running_loop()
        t0 = perf()
        with CpuMeter(server) as cpu:
            for seq in range(cfg.ping_count):
                if perf() - t0 > cfg.ping_seconds:
                    break
                fut = self.pending[seq] = loop.create_future()
                start = perf()
                self.pub.write_frame(self.frame(seq))
                try:
                    done = await asyncio.wait_for(fut, 2.0)
                except TimeoutError:
                    self.pending.pop(seq, None)
                    continue
                rtts.append(done - start)
        return {
            "n": len(rtts),
            "p50": pct(rtts, 50) * 1e3,
            "p99": pct(rtts, 99) * 1e3,
            "max": max(rtts) * 1e3 if rtts else float("nan"),
            "rate": len(rtts) / cpu.wall if cpu.wall else float("nan"),
            "cpu": cpu.pcts(),
        }


def print_relay(msg_size: int, results: dict[int, dict], ping: dict) -> None:
    print(
        f"\n[1] relay: std_msgs/String (~{msg_size} B frames), 1 publisher -> server -> "
        "1 subscriber"
    )
    rows = [
        [f"pipelined, window {window}", f"{r['recv']:,}/{r['sent']:,}", fnum(r["rate"]),
         f"{r['p50']:.2f}", f"{r['p99']:.2f}", "", *r["cpu"], f"{r['srv_us']:.1f}"]
        for window, r in results.items()
    ]
    rows.append(["ping-pong (1 in flight)", f"{ping['n']:,}", fnum(ping["rate"]),
                 f"{ping['p50']:.3f}", f"{ping['p99']:.3f}", f"{ping['max']:.2f}", *ping["cpu"],
                 ""])
    print(table(["run", "recv/sent", "msg/s", "p50 ms", "p99 ms", "max ms", "srv CPU",
                 "cli CPU", "srv us/msg"], rows))
    print(
        "  latency = receive time - send timestamp embedded in the data (one clock, one "
        "process); pipelined latency includes waiting in the window"
    )


async def relay_section(port: int, server: ServerProc, cfg: Config) -> dict:
    relay = Relay()
    await relay.open(port)
    await relay.warm_up()
    results = {window: await relay.pipelined(server, window, cfg) for window in cfg.windows}
    ping = await relay.ping_pong(server, cfg)
    await close_all([relay.pub, relay.sub])
    print_relay(relay.msg_size, results, ping)
    best = max(results, key=lambda w: results[w]["rate"])
    return {"rate": results[best]["rate"], "window": best, "ping_p50": ping["p50"],
            "ping_p99": ping["p99"]}


async def scenario(cfg: Config) -> list[str]:
    """Section [1] on a fresh server; returns its summary line."""
    server = start_ours(cfg.profile, "relay")
    try:
        r1 = await relay_section(server.port, server, cfg)
    finally:
        server.stop()
    return [
        f"relay String 1->1: {fnum(r1['rate'])} msg/s (window {r1['window']}); "
        f"ping-pong p50 {r1['ping_p50']:.3f} ms, p99 {r1['ping_p99']:.3f} ms"
    ]


if __name__ == "__main__":
    sys.exit(run_main(parser(__doc__.split("\n\n")[0]).parse_args(), scenario))

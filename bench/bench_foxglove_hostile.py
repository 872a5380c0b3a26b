"""Hostile Foxglove clients at the size issue 37 measured them (the tests in
tests/transport/test_foxglove_hostile.py run them scaled down).

Starts ``hitrobot-server`` (no robot) as a separate process per attack and prints the server's
resident memory (server + worker processes, from /proc) before, at its peak (sampled every
20 ms) and after the attacker left, and the round trips of a rosbridge witness calling
``/rosapi/get_time`` meanwhile (the issue's figures in the last column). Prints figures;
asserts nothing. Loopback only; every loop is bounded in count and time.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import struct
import sys
import threading
import time
from pathlib import Path

import numpy as np
from websockets.asyncio.client import connect

from hitrobot_server.bus.cdr import codec_for
from hitrobot_server.types.registry import TypeRegistry

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_hostile import MB, Server, Witness, row  # noqa: E402  (a sibling script)

FOX = "foxglove.websocket.v1"


class Peak:
    """The server's memory sampled every 20 ms in a thread."""

    def __init__(self, server: Server):
        self.server = server
        self.peak = server.mem()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.02):
            self.peak = max(self.peak, self.server.mem())

    def stop(self) -> float:
        self._stop.set()
        self._thread.join(5)
        return self.peak


async def fox(port: int):
    ws = await connect(f"ws://127.0.0.1:{port}", subprotocols=[FOX], max_size=None,
                       max_queue=1)
    await ws.recv()  # serverInfo
    return ws


async def until_id(ws, tag: str, timeout: float = 120.0) -> None:
    async with asyncio.timeout(timeout):
        while True:
            frame = await ws.recv()
            if isinstance(frame, str) and f'"id":"{tag}"' in frame:
                return


async def attack(server: Server, name: str, note: str, frames, *, reads: bool = True) -> None:
    """``frames`` sent by one Foxglove client (read until a sentinel when ``reads``, else
    never read and the connection dropped), a witness meanwhile."""
    (await fox(server.port)).transport.abort()  # the first Foxglove client learns the types
    async with connect(f"ws://127.0.0.1:{server.port}") as w:
        witness = Witness(w)
        await asyncio.sleep(0.3)
        witness.window()
        before = server.mem()
        peak = Peak(server)
        bad = await fox(server.port)
        if not reads:
            bad.transport.pause_reading()
        t0 = time.perf_counter()
        for i, frame in enumerate(frames):
            await bad.send(frame)
            if i % 64 == 63:  # the witness shares this loop: let it measure, not wait on us
                await asyncio.sleep(0)
        if reads:
            await bad.send(json.dumps({"op": "getParameters", "parameterNames": ["/none"],
                                       "id": "end"}))
            await until_id(bad, "end")
        else:
            await asyncio.sleep(2)  # what it costs while it stays connected
        took = time.perf_counter() - t0
        bad.transport.abort()
        await asyncio.sleep(1)
        row(name, before, peak.stop(), server.mem(), f"{took:.1f} s; {note}", witness.window())
        await witness.close()


def subscribes(count: int) -> list[str]:
    return [json.dumps({"op": "subscribe", "subscriptions": [
        {"id": base + i, "channelId": 3_000_000 + base + i} for i in range(10_000)]})
        for base in range(0, count, 10_000)]


def unsubscribes(count: int) -> list[str]:
    return [json.dumps({"op": "unsubscribe", "subscriptionIds": list(
        range(5_000_000 + base, 5_000_000 + base + 10_000))}) for base in range(0, count, 10_000)]


def churn(rounds: int) -> list[str]:
    out = []
    for r in range(rounds):
        out.append(json.dumps({"op": "advertise", "channels": [
            {"id": i, "topic": f"/churn/r{r}/t{i}", "encoding": "cdr",
             "schemaName": "std_msgs/msg/String"} for i in range(1, 10_001)]}))
        out.append(json.dumps({"op": "unadvertise", "channelIds": list(range(1, 10_001))}))
    return out


def scan(points: int) -> bytes:
    types = TypeRegistry.default()
    msg = {"header": {"stamp": {"secs": 1, "nsecs": 0}, "frame_id": "laser", "seq": 0},
           "angle_min": -1.0, "angle_max": 1.0, "angle_increment": 0.001,
           "time_increment": 0.0, "scan_time": 0.1, "range_min": 0.1, "range_max": 30.0,
           "ranges": np.random.default_rng(1).random(points, dtype=np.float32),
           "intensities": []}
    return struct.pack("<BI", 1, 1) + codec_for(types).encode(
        msg, types.msg("sensor_msgs/LaserScan"))


async def subscription_ids(server: Server, count: int) -> None:
    async with connect(f"ws://127.0.0.1:{server.port}") as pub:
        await pub.send(json.dumps({"op": "advertise", "topic": "/scan_like",
                                   "type": "std_msgs/String"}))
        probe = await fox(server.port)
        channel = None
        async with asyncio.timeout(30):
            while channel is None:
                frame = await probe.recv()
                if isinstance(frame, str) and '"/scan_like"' in frame:
                    channel = next(c["id"] for c in json.loads(frame).get("channels", [])
                                   if c["topic"] == "/scan_like")
        await probe.close()
        frames = [json.dumps({"op": "subscribe", "subscriptions": [
            {"id": base + i, "channelId": channel} for i in range(10_000)]})
            for base in range(0, count, 10_000)]
        await attack(server, f"{count:,} subscription ids on one topic", "16 kept per "
                     "channel (was all: 7.9 s)", frames)


async def main(quick: bool) -> None:
    n = 10 if quick else 1
    print("hostile Foxglove clients (issue 37): server + worker RSS in MB; witness = "
          "/rosapi/get_time round trips of a rosbridge client meanwhile")
    print(f"  {'attack':<34} {'before':>7} {'peak':>7} {'after':>7}  {'witness':<26} note")
    params = [json.dumps({"op": "setParameters", "parameters": [
        {"name": f"/big/p{i}", "value": "v" * 990_000} for i in range(15)]})]
    attacks = [
        lambda s: attack(s, f"{100_000 // n:,} subscribes, unknown channels",
                         "one status per op (was 3.3 s)", subscribes(100_000 // n)),
        lambda s: attack(s, f"{100_000 // n:,} unsubscribes, unknown ids",
                         "one status per op (was 2.2 s)", unsubscribes(100_000 // n)),
        lambda s: subscription_ids(s, 100_000 // n),
        lambda s: attack(s, "10,000 channels (un)advertised x3", "1,024 kept per client "
                         "(was 18.3 s)", churn(3)),
        lambda s: attack(s, "98 getParameters (15 MB), no reads",
                         "reply budget (was +1.5 GB)",
                         params + [json.dumps({"op": "getParameters", "parameterNames": [],
                                               "id": f"g{i}"}) for i in range(98)],
                         reads=False),
        lambda s: attack(s, f"{300_000 // n:,} calls, unknown service",
                         "reply budget, statuses limited (was +1.2 GB)",
                         [struct.pack("<BIII", 2, 4_000_000, i, 3) + b"cdr"
                          for i in range(300_000 // n)], reads=False),
        lambda s: attack(s, f"{200_000 // n:,} junk frames, no reads",
                         "statuses limited (was +638 MB)",
                         ["{not json" if i % 2 else b"\x07junk" for i in range(200_000 // n)],
                         reads=False),
        lambda s: attack(s, f"a {50 // n} MB LaserScan published", "flat: decoded as a copy "
                         "(was +479 MB, 0.54 s)",
                         [json.dumps({"op": "advertise", "channels": [
                             {"id": 1, "topic": "/big_scan", "encoding": "cdr",
                              "schemaName": "sensor_msgs/msg/LaserScan"}]}),
                          scan(50 * MB // 4 // n)]),
    ]
    for run in attacks:  # each on a fresh server, so that its peak is its own
        server = Server()
        try:
            with contextlib.suppress(TimeoutError):
                await run(server)
        finally:
            server.stop()
    print("  (2 shared cores: timings are indicative only)")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a tenth of each attack")
    asyncio.run(main(parser.parse_args().quick))

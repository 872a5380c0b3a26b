"""Hostile Foxglove clients at the size issue 37 measured them (the tests in
tests/session/foxglove/test_clients_that_never_read.py run them scaled down).

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
from websockets.exceptions import ConnectionClosed

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


class ThreadWitness:
    """The rosbridge witness on its own event loop in a thread: the attacker's work in this
    process (building and sending 300,000 frames) is not counted as the server's."""

    def __init__(self, port: int):
        self.port = port
        self._witness: Witness | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._ready = threading.Event()
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=lambda: asyncio.run(self._run()), daemon=True)
        self._thread.start()
        self._ready.wait(30)

    async def _run(self) -> None:
        self._loop, self._stop = asyncio.get_running_loop(), asyncio.Event()
        async with connect(f"ws://127.0.0.1:{self.port}") as w:
            self._witness = Witness(w)
            self._ready.set()
            await self._stop.wait()
            await self._witness.close()

    def window(self) -> str:
        return asyncio.run_coroutine_threadsafe(self._window(), self._loop).result(30)

    async def _window(self) -> str:
        return self._witness.window()

    def close(self) -> None:
        self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(30)


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


async def attack(server: Server, name: str, note: str, frames, *, reads: bool = True,
                 trim_wait: float = 0.0) -> None:
    """``frames`` sent by one Foxglove client (read until a sentinel when ``reads``, else
    never read and the connection dropped), a witness meanwhile."""
    (await fox(server.port)).transport.abort()  # the first Foxglove client learns the types
    witness = ThreadWitness(server.port)
    await asyncio.sleep(0.3)
    witness.window()
    before = server.mem()
    peak = Peak(server)
    bad = await fox(server.port)
    if not reads:
        bad.transport.pause_reading()
    t0 = time.perf_counter()
    try:
        for frame in frames:
            await bad.send(frame)
        if reads:
            await bad.send(json.dumps({"op": "getParameters", "parameterNames": ["/none"],
                                       "id": "end"}))
            await until_id(bad, "end")
        else:
            await asyncio.sleep(2)  # what it costs while it stays connected
    except ConnectionClosed as exc:  # the server ended it (over its reply budget)
        note += f"; disconnected after {time.perf_counter() - t0:.1f} s ({exc.rcvd})"
    took = time.perf_counter() - t0
    bad.transport.abort()
    await asyncio.sleep(1)
    after = server.mem()
    if trim_wait:  # the memory returned once the server trimmed its heap
        await asyncio.sleep(trim_wait)
        after = server.mem()
    row(name, before, peak.stop(), after, f"{took:.1f} s; {note}", witness.window())
    witness.close()


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


async def main(quick: bool, only: set[int]) -> None:
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
                         reads=False, trim_wait=3.0),
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
    for i, run in enumerate(attacks):  # each on a fresh server, so that its peak is its own
        if only and i + 1 not in only:
            continue
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
    parser.add_argument("--only", type=int, nargs="*", default=[],
                        help="run only these attacks (1-8, in the table's order)")
    args = parser.parse_args()
    asyncio.run(main(args.quick, set(args.only)))

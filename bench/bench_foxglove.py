#!/usr/bin/env python3
"""LaserScan fan-out to Foxglove clients vs rosbridge clients on one server (msg/s, CPU).

Prints figures only. A rosbridge client publishes sensor_msgs/LaserScan (720 ranges) as fast as
the server takes it; N subscribers are either rosbridge clients (JSON ``publish`` ops, encoded
once per message) or Foxglove clients (``foxglove.websocket.v1``: binary message data, the CDR
encoded once per message and shared). Each run has a fresh server in its own process
(``--robot none``, loopback, ephemeral port); the subscribers are the header-only clients of
wsclient.py. Every loop is bounded in count and time.

    .venv/bin/python bench/bench_foxglove.py            # 50 clients of each kind, ~1 min
    .venv/bin/python bench/bench_foxglove.py --clients 10 --count 500
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from pathlib import Path

import orjson

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchlib import (  # noqa: E402
    CpuMeter,
    ScanSource,
    fnum,
    start_ours,
    table,
    verify_scan_samples,
)
from wsclient import RawWs, close_all, perf, warm_up, ws_frame  # noqa: E402

from hitrobot_server.bus.cdr import codec_for  # noqa: E402
from hitrobot_server.types.registry import TypeRegistry  # noqa: E402

TOPIC = "/bench/scan"


class FoxWs(RawWs):
    """A header-only Foxglove client: subscribes to TOPIC once it is advertised, counts message
    data frames (binary opcode 1, told apart by their first byte without copying them) and
    keeps a sample of their CDR. ``last_data`` is the arrival of the last message data: the
    ``time`` frames that keep coming afterwards must not stretch the measured interval."""

    extra_headers = "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n"

    def __init__(self, **kw):
        super().__init__(on_message=self._on_message, **kw)
        self.data = 0
        self.last_data = 0.0
        self.cdr_samples: list[bytes] = []
        self.subscribed: asyncio.Future = asyncio.get_running_loop().create_future()

    def _message(self, buf: bytearray, start: int, end: int, fin: int, now: float) -> None:
        if fin and not self._parts and end > start and buf[start] == 1:
            self.data += 1
            self.nbytes += end - start
            self.last_data = now
            if self.data % 500 == 1:
                self.cdr_samples.append(bytes(buf[start + 13 : end]))
            return
        super()._message(buf, start, end, fin, now)

    def _on_message(self, payload: bytes, now: float) -> None:
        if payload[:1] == b"{":
            op = orjson.loads(payload)
            if op.get("op") == "advertise" and not self.subscribed.done():
                for chan in op["channels"]:
                    if chan["topic"] == TOPIC:
                        self.send({"op": "subscribe",
                                   "subscriptions": [{"id": 1, "channelId": chan["id"]}]})
                        self.subscribed.set_result(None)

    def reset(self) -> None:
        super().reset()
        self.data = 0
        self.last_data = 0.0


async def run(kind: str, n_clients: int, count: int, seconds: float) -> dict:
    server = start_ours(None, f"{kind}_{n_clients}")
    try:
        src = ScanSource(TOPIC)
        pub = await RawWs.open(server.port)
        pub.send({"op": "advertise", "topic": TOPIC, "type": "sensor_msgs/LaserScan"})
        subs: list[RawWs] = []
        for k in range(0, n_clients, 25):
            batch = min(25, n_clients - k)
            if kind == "foxglove":
                subs += await asyncio.gather(*(FoxWs.open(server.port) for _ in range(batch)))
            else:
                subs += await asyncio.gather(
                    *(RawWs.open(server.port, sample_every=max(count // 10, 1))
                      for _ in range(batch)))
        if kind == "foxglove":
            await asyncio.wait_for(asyncio.gather(*(s.subscribed for s in subs)), 20)
        else:
            for s in subs:
                s.send({"op": "subscribe", "topic": TOPIC, "type": "sensor_msgs/LaserScan"})

        def got(s: RawWs) -> int:
            return s.data if kind == "foxglove" else s.count

        await warm_up(pub, src, subs, got)
        with CpuMeter(server) as cpu:
            t0 = perf()
            sent = 0
            while sent < count and perf() < t0 + seconds:
                pub.write_frame(ws_frame(src.frame(sent)))
                sent += 1
                await pub.drain()
            expected = sent * n_clients
            last, changed = -1, perf()
            while perf() < t0 + seconds + 30:
                total = sum(got(s) for s in subs)
                if total >= expected:
                    break
                if total != last:
                    last, changed = total, perf()
                elif perf() - changed > 2.0:
                    break  # no progress for 2 s: the rest was dropped (bounded buffers)
                await asyncio.sleep(0.01)
            t_end = max(s.last_data if kind == "foxglove" else s.last_rx for s in subs)
        total = sum(got(s) for s in subs)
        elapsed = t_end - t0
        if kind == "foxglove":
            codec = codec_for(TypeRegistry.default())
            mtype = TypeRegistry.default().msg("sensor_msgs/LaserScan")
            samples = [c for s in subs for c in s.cdr_samples]
            bad = sum(len(codec.decode(c, mtype)["ranges"]) != 720 for c in samples)
            checked = len(samples)
        else:
            checked, bad, _ = verify_scan_samples(subs, TOPIC, 10**9)
        await close_all([pub, *subs])
        return {
            "kind": kind, "clients": n_clients, "sent": sent, "total": total,
            "expected": expected, "elapsed": elapsed, "rate": total / elapsed,
            "cpu": cpu.pcts(elapsed)[0], "us": 1e6 * cpu.server_s / total if total else 0.0,
            "ok": f"{checked - bad}/{checked}",
        }
    finally:
        server.stop()


async def main(args) -> None:
    runs = []
    for kind in ("rosbridge", "foxglove"):
        runs.append(await run(kind, args.clients, args.count, args.seconds))
    print(f"LaserScan (720 ranges) fan-out to {args.clients} clients, one server process, "
          "loopback (a shared 2-core machine: indicative figures)")
    print(table(
        ["protocol", "clients", "msgs", "recv/expected", "s", "msg/s total", "srv CPU",
         "srv us/msg", "samples ok"],
        [[r["kind"], r["clients"], r["sent"], f"{r['total']:,}/{r['expected']:,}",
          f"{r['elapsed']:.2f}", fnum(r["rate"]), r["cpu"], f"{r['us']:.1f}", r["ok"]]
         for r in runs],
    ))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--count", type=int, default=2000, help="scans to publish per run")
    parser.add_argument("--seconds", type=float, default=20.0, help="most seconds publishing")
    asyncio.run(main(parser.parse_args()))

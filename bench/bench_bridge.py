#!/usr/bin/env python3
"""Loopback benchmark of hitrobot-server: relay rate, LaserScan fan-out, big maps, and a ceiling.

Prints figures only (no assertions, no pass/fail). Everything runs on 127.0.0.1 with ephemeral
ports; every loop is bounded in count and in time. The server under test runs as a separate
process (``python -m hitrobot_server``), and so does the ceiling server (this file with
``--ceiling-server``), so the measuring clients never share an event loop with the server.

    .venv/bin/python bench/bench_bridge.py            # full run, about 2 minutes on 2 cores
    .venv/bin/python bench/bench_bridge.py --quick    # about 20 s
    .venv/bin/python bench/bench_bridge.py --profile-server /tmp/prof   # cProfile each server

Sections:
  1. relay      std_msgs/String, 1 publisher -> server -> 1 subscriber: a pipelined run with a
                bounded in-flight window (throughput) and a ping-pong run (latency).
  2. fan-out    sensor_msgs/LaserScan (720 ranges) published at max rate to 1/10/50 clients.
  3. map        2000x2000 nav_msgs/OccupancyGrid on a latched topic, compression none / png.
  4. ceiling    section 2 against a bare ``websockets`` server that only broadcasts the frames
                it is sent, and the ratio of our delivered rate (and server CPU) to it.
  5. probe      a client (its own process) calls /rosapi/get_time every 5 ms while 2000x2000
                and 4000x4000 maps are published to a png and an uncompressed subscriber.
  6. memory     server RSS with 1000 idle WebSocket clients, and while a subscriber stops
                reading for 30 s (10 s with --quick).

Subscribers in sections 1, 2 and 4 are minimal WebSocket clients written on asyncio.Protocol:
they parse frame headers only, count frames and bytes, and keep a sample of payloads, which is
decoded and checked after the run. The publisher masks its frames ahead of time where it can.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import contextlib
import io
import itertools
import os
import platform
import random
import re
import resource
import shlex
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import orjson
from PIL import Image

from hitrobot_server import procmem

try:
    from websockets.speedups import apply_mask
except ImportError:  # pure-Python fallback
    from websockets.utils import apply_mask

HOST = "127.0.0.1"
SERVER_ARGS: list[str] = []  # --server-args: more flags for every hitrobot-server started
ROOT = Path(__file__).resolve().parent.parent
perf = time.perf_counter


# ======================================================================= minimal WS client
def ws_frame(payload: bytes, opcode: int = 0x1) -> bytes:
    """One masked client frame (FIN set)."""
    n = len(payload)
    if n < 126:
        head = bytes((0x80 | opcode, 0x80 | n))
    elif n < 65536:
        head = bytes((0x80 | opcode, 0x80 | 126)) + n.to_bytes(2, "big")
    else:
        head = bytes((0x80 | opcode, 0x80 | 127)) + n.to_bytes(8, "big")
    key = random.randbytes(4)
    return head + key + apply_mask(payload, key)


class RawWs(asyncio.Protocol):
    """A bare WebSocket client: header-only frame parsing, counts, optional payload hooks.

    ``sample_every``: keep the payload of message 1, 1+k, 1+2k, ... (0 = keep none).
    ``on_message(payload, t_chunk)``: called with every payload when set (costs a copy).
    ``on_first_byte(t)``: called once, when the first byte of a data frame arrives.
    """

    extra_headers = ""  # more handshake header lines ("Name: value\r\n"), e.g. a subprotocol

    def __init__(self, *, sample_every: int = 0, on_message: Callable | None = None):
        loop = asyncio.get_running_loop()
        self.ready: asyncio.Future = loop.create_future()
        self.closed: asyncio.Future = loop.create_future()
        self.transport: asyncio.Transport | None = None
        self._hs = bytearray()
        self._opened = False
        self._buf = bytearray()
        self._parts: list[bytes] = []
        self._paused: asyncio.Future | None = None
        self.sample_every = sample_every
        self.on_message = on_message
        self.on_first_byte: Callable | None = None
        self.count = 0
        self.nbytes = 0
        self.first_rx = 0.0
        self.last_rx = 0.0
        self.samples: list[bytes] = []

    @classmethod
    async def open(cls, port: int, **kw) -> RawWs:
        loop = asyncio.get_running_loop()
        _, proto = await loop.create_connection(lambda: cls(**kw), HOST, port)
        await asyncio.wait_for(proto.ready, 10)
        return proto

    # ----------------------------------------------------------------- asyncio.Protocol
    def connection_made(self, transport) -> None:
        self.transport = transport
        key = base64.b64encode(random.randbytes(16)).decode()
        transport.write(
            (
                f"GET / HTTP/1.1\r\nHost: {HOST}\r\nUpgrade: websocket\r\n"
                f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n{self.extra_headers}"
                "Sec-WebSocket-Version: 13\r\n\r\n"
            ).encode()
        )

    def connection_lost(self, exc) -> None:
        if not self.ready.done():
            self.ready.set_exception(ConnectionError("closed during handshake"))
        if not self.closed.done():
            self.closed.set_result(None)
        if self._paused is not None and not self._paused.done():
            self._paused.set_result(None)

    def pause_writing(self) -> None:
        if self._paused is None or self._paused.done():
            self._paused = asyncio.get_running_loop().create_future()

    def resume_writing(self) -> None:
        if self._paused is not None and not self._paused.done():
            self._paused.set_result(None)

    def data_received(self, data: bytes) -> None:
        if not self._opened:
            self._hs += data
            end = self._hs.find(b"\r\n\r\n")
            if end < 0:
                return
            head, data = bytes(self._hs[:end]), bytes(self._hs[end + 4 :])
            if not head.startswith(b"HTTP/1.1 101"):
                self.ready.set_exception(ConnectionError(head.decode(errors="replace")))
                return
            self._opened = True
            self.ready.set_result(None)
            if not data:
                return
        now = perf()
        buf = self._buf
        if not buf and self.on_first_byte is not None:
            self.on_first_byte(now)
            self.on_first_byte = None
        buf += data
        n = len(buf)
        pos = 0
        while n - pos >= 2:
            b0, b1 = buf[pos], buf[pos + 1]
            length = b1 & 0x7F
            head = 2
            if length == 126:
                if n - pos < 4:
                    break
                length = int.from_bytes(buf[pos + 2 : pos + 4], "big")
                head = 4
            elif length == 127:
                if n - pos < 10:
                    break
                length = int.from_bytes(buf[pos + 2 : pos + 10], "big")
                head = 10
            if b1 & 0x80:  # servers do not mask, but be correct anyway
                head += 4
            end = pos + head + length
            if end > n:
                break
            opcode = b0 & 0x0F
            if opcode <= 0x2:
                self._message(buf, pos + head, end, b0 & 0x80, now)
            elif opcode == 0x9:  # ping -> pong
                with memoryview(buf) as mv:
                    self.transport.write(ws_frame(bytes(mv[pos + head : end]), 0xA))
            elif opcode == 0x8:
                self.transport.close()
            pos = end
        if pos:
            del buf[:pos]
        if buf and self.on_first_byte is not None:
            self.on_first_byte(now)
            self.on_first_byte = None

    def _message(self, buf: bytearray, start: int, end: int, fin: int, now: float) -> None:
        want = self.on_message is not None or self._parts or not fin
        if not want and self.sample_every:
            want = self.count % self.sample_every == 0
        payload = b""
        if want:
            with memoryview(buf) as mv:
                payload = bytes(mv[start:end])
        if not fin:
            self._parts.append(payload)
            return
        if self._parts:
            payload = b"".join(self._parts) + payload
            self._parts = []
        if self.count == 0:
            self.first_rx = now
        self.count += 1
        self.nbytes += len(payload) if payload else end - start
        self.last_rx = now
        if self.sample_every and (self.count - 1) % self.sample_every == 0:
            self.samples.append(payload)
        if self.on_message is not None:
            self.on_message(payload, now)

    # ----------------------------------------------------------------- sending
    def send(self, obj_or_bytes) -> None:
        data = obj_or_bytes if isinstance(obj_or_bytes, bytes) else orjson.dumps(obj_or_bytes)
        self.transport.write(ws_frame(data))

    def write_frame(self, frame: bytes) -> None:
        self.transport.write(frame)

    async def drain(self) -> None:
        if self._paused is not None and not self._paused.done():
            await self._paused

    def reset(self) -> None:
        self.count = self.nbytes = 0
        self.first_rx = self.last_rx = 0.0
        self.samples = []

    async def close(self) -> None:
        if self.transport is None or self.transport.is_closing():
            return
        with contextlib.suppress(Exception):
            self.transport.write(ws_frame((1000).to_bytes(2, "big"), 0x8))
            await asyncio.wait_for(asyncio.shield(self.closed), 0.5)
        self.transport.close()


async def warm_up(pub, src, subs, got) -> None:
    """Publish scans until every subscriber has some (``got(s)`` > 0; no reply ops needed, so
    it works for any server), let the stragglers in, then zero the counters: the measured run
    starts with every subscription flowing. Bounded: 10 s."""
    deadline, k = perf() + 10, 0
    while perf() < deadline and min(got(s) for s in subs) == 0:
        pub.write_frame(ws_frame(src.frame(k)))
        k += 1
        await asyncio.sleep(0.05)
    await asyncio.sleep(0.3)
    for s in subs:
        s.reset()


async def close_all(clients) -> None:
    await asyncio.gather(*(c.close() for c in clients), return_exceptions=True)


# ======================================================================= server processes
class ServerProc:
    """A server in a child process on an ephemeral loopback port, with its CPU time."""

    def __init__(self, argv: list[str], pattern: str, label: str, tree: str | None = None):
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        if tree is not None:
            env["PYTHONPATH"] = str(Path(tree).resolve())
        self.label = label
        self.proc = subprocess.Popen(
            argv,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=env,
            cwd=tree or ROOT,
        )
        self.output: list[str] = []
        deadline = time.monotonic() + 30
        self.port = None
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            self.output.append(line)
            m = re.search(pattern, line)
            if m:
                self.port = int(m.group(1))
                break
        if self.port is None:
            self.stop()
            raise RuntimeError(f"{label} did not start:\n" + "".join(self.output))
        # keep draining its output so a chatty server never blocks on a full pipe
        threading.Thread(target=self._drain, daemon=True).start()

    def _drain(self) -> None:
        for line in self.proc.stdout:
            self.output.append(line)

    def cpu(self) -> float:
        """User+system CPU seconds of the process so far."""
        try:
            fields = Path(f"/proc/{self.proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
            return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except (OSError, IndexError, ValueError):
            return float("nan")

    def _pids(self) -> list[int]:
        """The server and its worker processes (the pool that parses and encodes big ops)."""
        return [self.proc.pid, *procmem.children(self.proc.pid)]

    def rss_mb(self) -> float:
        """Peak resident set size (VmHWM) of the server plus each worker's peak, MB (the peaks
        may be at different times: an upper bound of the peak of the sum)."""
        return sum(procmem.peak_bytes(pid) for pid in self._pids()) / 2**20

    def rss_now_mb(self) -> float:
        """Resident set size right now (VmRSS) of the server and its workers, MB."""
        return sum(procmem.rss_bytes(pid) for pid in self._pids()) / 2**20

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)


RECORD_DIR: str | None = None  # set by --record
_record_runs = itertools.count()


def start_ours(profile_dir: str | None, tag: str, extra: list[str] | tuple = (),
               tree: str | None = None) -> ServerProc:
    """hitrobot-server with the bench's flags, ``extra`` flags after them; ``tree``: run the
    package from that source tree instead of this one (e.g. main's, for a before/after run)."""
    args = [
        "-m",
        "hitrobot_server",
        "--port",
        "0",
        "--tcp-port",
        "0",
        "--address",
        HOST,
        "--log-level",
        "warning",
        "--robot",  # the bridge alone: no simulator competing for the core
        "none",
        *SERVER_ARGS,
        *extra,
    ]
    if RECORD_DIR:  # --record: every server also records everything it carries
        args += ["--record", str(Path(RECORD_DIR) / f"{tag}_{next(_record_runs)}.mcap")]
    if profile_dir:
        Path(profile_dir).mkdir(parents=True, exist_ok=True)
        args = ["-m", "cProfile", "-o", str(Path(profile_dir) / f"{tag}.prof"), *args]
    return ServerProc([sys.executable, *args], r"ws://[\d.]+:(\d+)", "hitrobot-server", tree)


CEILING_LIB = ["websockets"]  # --ceiling-lib


def start_ceiling() -> ServerProc:
    return ServerProc(
        [sys.executable, str(Path(__file__).resolve()), "--ceiling-server", CEILING_LIB[0]],
        r"ceiling ws://[\d.]+:(\d+)",
        "ceiling server",
    )


def picows_ceiling_main() -> None:
    """The same bare broadcast on picows (a Cython WebSocket layer), to see what a faster
    WebSocket layer would leave of the transport's share (issue 38 item 3). Not a dependency:
    ``pip install picows`` to run it."""
    from picows import WSListener, WSMsgType, ws_create_server

    subs: set = set()

    class Peer(WSListener):
        def on_ws_connected(self, transport) -> None:
            self.transport = transport

        def on_ws_frame(self, transport, frame) -> None:
            kind = frame.msg_type
            if kind == WSMsgType.TEXT:
                data = frame.get_payload_as_bytes()
                if data.startswith(b'{"op":"publish"'):
                    for peer in subs:
                        peer.transport.send(WSMsgType.TEXT, data)
                elif orjson.loads(data).get("op") == "subscribe":
                    subs.add(self)
            elif kind == WSMsgType.PING:
                transport.send_pong(frame.get_payload_as_bytes())
            elif kind == WSMsgType.CLOSE:
                transport.send_close(frame.get_close_code())
                transport.disconnect()

        def on_ws_disconnected(self, transport) -> None:
            subs.discard(self)

    async def main() -> None:
        server = await ws_create_server(lambda request: Peer(), HOST, 0)
        await serve_until_signalled(server)

    asyncio.run(main())


async def serve_until_signalled(server) -> None:
    """Print the ceiling's address (what ``start_ceiling`` waits for) and serve until
    SIGINT/SIGTERM."""
    port = server.sockets[0].getsockname()[1]
    print(f"ceiling ws://{HOST}:{port}", flush=True)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    await stop.wait()


def ceiling_server_main() -> None:
    """A bare websockets server: subscribers register; every publish frame is broadcast
    unchanged (already-encoded JSON bytes, no parsing) to all subscribers."""
    from websockets.asyncio.server import broadcast, serve
    from websockets.exceptions import ConnectionClosed

    async def main() -> None:
        subs: set = set()

        async def handler(ws) -> None:
            try:
                while True:
                    frame = await ws.recv(decode=False)
                    if frame.startswith(b'{"op":"publish"'):
                        broadcast(subs, frame, text=True)
                    elif orjson.loads(frame).get("op") == "subscribe":
                        subs.add(ws)
            except ConnectionClosed:
                pass
            finally:
                subs.discard(ws)

        # the same transport settings as hitrobot_server/transport/websocket.py
        async with serve(
            handler, HOST, 0, max_size=None, compression=None, ping_interval=None, max_queue=64
        ) as server:
            await serve_until_signalled(server)

    asyncio.run(main())


# ======================================================================= output helpers
def table(headers: list[str], rows: list[list]) -> str:
    cells = [[str(h) for h in headers]] + [[str(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    lines = []
    for k, r in enumerate(cells):
        lines.append(
            "  "
            + "  ".join(
                c.rjust(w) if j else c.ljust(w)
                for j, (c, w) in enumerate(zip(r, widths, strict=True))
            )
        )
        if k == 0:
            lines.append("  " + "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def pct(values, q: float) -> float:
    return float(np.percentile(np.asarray(values), q)) if len(values) else float("nan")


def fnum(x: float, digits: int = 0) -> str:
    if x != x:  # nan
        return "n/a"
    return f"{x:,.{digits}f}"


class CpuMeter:
    """Server CPU seconds and this (client) process's CPU seconds over a measured window."""

    def __init__(self, server: ServerProc):
        self.server = server

    def __enter__(self) -> CpuMeter:
        self.s0, self.c0, self.t0 = self.server.cpu(), time.process_time(), perf()
        return self

    def __exit__(self, *exc) -> None:
        self.wall = perf() - self.t0
        self.server_s = self.server.cpu() - self.s0
        self.client_s = time.process_time() - self.c0

    def pcts(self, wall: float | None = None) -> tuple[str, str]:
        w = wall or self.wall
        return f"{100 * self.server_s / w:.0f}%", f"{100 * self.client_s / w:.0f}%"


async def barrier(client: RawWs, tag: str, timeout: float = 10.0) -> None:
    """Wait until the server has processed everything this client sent before (ops of one
    connection are handled in order): call /rosapi/get_time and wait for its response."""
    op_id = f"barrier:{tag}:{time.monotonic_ns()}".encode()
    got = asyncio.get_running_loop().create_future()
    prev = client.on_message

    def hook(payload: bytes, now: float) -> None:
        if op_id in payload and b"service_response" in payload and not got.done():
            got.set_result(None)
        if prev is not None:
            prev(payload, now)

    client.on_message = hook
    try:
        client.send({"op": "call_service", "id": op_id.decode(), "service": "/rosapi/get_time"})
        await asyncio.wait_for(got, timeout)
    finally:
        client.on_message = prev


# ======================================================================= 1. relay
async def relay_section(port: int, server: ServerProc, cfg) -> dict:
    topic = "/bench/relay"
    pub = await RawWs.open(port)
    inflight_wake = asyncio.Event()
    state = {"recv": 0, "lat": [], "pending": {}}
    prefix = b'{"op":"publish","topic":"' + topic.encode() + b'","msg":{"data":"'

    def on_msg(payload: bytes, now: float) -> None:
        # data is "<seq> <perf_counter_ns at send>"
        i = payload.find(b'"data":"')
        if i < 0:
            return
        j = payload.find(b'"', i + 8)
        seq_s, ts = payload[i + 8 : j].split(b" ")
        state["recv"] += 1
        state["lat"].append(now - int(ts) / 1e9)
        fut = state["pending"].pop(int(seq_s), None)
        if fut is not None and not fut.done():
            fut.set_result(now)
        inflight_wake.set()

    sub = await RawWs.open(port, on_message=on_msg)
    pub.send({"op": "advertise", "topic": topic, "type": "std_msgs/String"})
    sub.send({"op": "subscribe", "topic": topic, "type": "std_msgs/String"})
    await barrier(pub, "relay-pub")
    await barrier(sub, "relay-sub")

    def frame(seq: int) -> bytes:
        return ws_frame(prefix + f'{seq} {time.perf_counter_ns()}"}}}}'.encode())

    # warm up (also proves the path works)
    for k in range(200):
        pub.write_frame(frame(10_000_000 + k))
    deadline = perf() + 5
    while state["recv"] < 200 and perf() < deadline:
        await asyncio.sleep(0.01)
    msg_size = len(prefix) + 30

    # --- pipelined throughput: bounded in-flight window
    results = {}
    for window in cfg.windows:
        state["recv"], state["lat"] = 0, []
        sent = 0
        with CpuMeter(server) as cpu:
            t0 = perf()
            stop_at = t0 + cfg.relay_seconds
            while sent < cfg.relay_count and perf() < stop_at:
                while sent - state["recv"] >= window:
                    inflight_wake.clear()
                    try:
                        await asyncio.wait_for(inflight_wake.wait(), 2.0)
                    except TimeoutError:
                        break
                    if perf() >= stop_at + 2:
                        break
                if sent - state["recv"] >= window:
                    break  # stuck: nothing came back for 2 s
                pub.write_frame(frame(sent))
                sent += 1
                if sent % 64 == 0:
                    await pub.drain()
            deadline = perf() + 3
            while state["recv"] < sent and perf() < deadline:
                await asyncio.sleep(0.005)
            elapsed = sub.last_rx - t0
        lat = state["lat"]
        results[window] = {
            "sent": sent,
            "recv": state["recv"],
            "elapsed": elapsed,
            "rate": state["recv"] / elapsed if elapsed > 0 else float("nan"),
            "p50": pct(lat, 50) * 1e3,
            "p99": pct(lat, 99) * 1e3,
            "cpu": cpu.pcts(elapsed),
            "srv_us": 1e6 * cpu.server_s / state["recv"] if state["recv"] else float("nan"),
        }

    # --- ping-pong latency: one message in flight
    state["recv"], state["lat"] = 0, []
    rtts = []
    loop = asyncio.get_running_loop()
    t0 = perf()
    with CpuMeter(server) as cpu:
        for seq in range(cfg.ping_count):
            if perf() - t0 > cfg.ping_seconds:
                break
            fut = state["pending"][seq] = loop.create_future()
            start = perf()
            pub.write_frame(frame(seq))
            try:
                done = await asyncio.wait_for(fut, 2.0)
            except TimeoutError:
                state["pending"].pop(seq, None)
                continue
            rtts.append(done - start)
    ping = {
        "n": len(rtts),
        "p50": pct(rtts, 50) * 1e3,
        "p99": pct(rtts, 99) * 1e3,
        "max": max(rtts) * 1e3 if rtts else float("nan"),
        "rate": len(rtts) / cpu.wall if cpu.wall else float("nan"),
        "cpu": cpu.pcts(),
    }
    await close_all([pub, sub])

    print(
        f"\n[1] relay: std_msgs/String (~{msg_size} B frames), 1 publisher -> server -> "
        "1 subscriber"
    )
    rows = []
    for window, r in results.items():
        rows.append(
            [
                f"pipelined, window {window}",
                f"{r['recv']:,}/{r['sent']:,}",
                fnum(r["rate"]),
                f"{r['p50']:.2f}",
                f"{r['p99']:.2f}",
                "",
                *r["cpu"],
                f"{r['srv_us']:.1f}",
            ]
        )
    rows.append(
        [
            "ping-pong (1 in flight)",
            f"{ping['n']:,}",
            fnum(ping["rate"]),
            f"{ping['p50']:.3f}",
            f"{ping['p99']:.3f}",
            f"{ping['max']:.2f}",
            *ping["cpu"],
            "",
        ]
    )
    print(
        table(
            [
                "run",
                "recv/sent",
                "msg/s",
                "p50 ms",
                "p99 ms",
                "max ms",
                "srv CPU",
                "cli CPU",
                "srv us/msg",
            ],
            rows,
        )
    )
    print(
        "  latency = receive time - send timestamp embedded in the data (one clock, one "
        "process); pipelined latency includes waiting in the window"
    )
    best = max(results.values(), key=lambda r: r["rate"])
    return {
        "rate": best["rate"],
        "window": max(results, key=lambda w: results[w]["rate"]),
        "ping_p50": ping["p50"],
        "ping_p99": ping["p99"],
    }


# ======================================================================= 2/4. fan-out
class ScanSource:
    """Pre-encoded LaserScan publish ops: a pool of pre-encoded 720-value ``ranges`` arrays
    joined with a per-message ``header.seq`` (a bytes concatenation, not a JSON encode).
    Ranges are float32 values printed as doubles, as rosbridge sends them (2.3450000286102295).
    """

    def __init__(self, topic: str, pool: int = 64):
        rng = np.random.default_rng(3)
        self.ranges = [
            orjson.dumps(rng.uniform(0.1, 30.0, 720).astype(np.float32).astype(float).tolist())
            for _ in range(pool)
        ]
        msg = {
            "header": {"seq": 0, "stamp": {"secs": 1_700_000_000, "nsecs": 0}, "frame_id": "laser"},
            "angle_min": -3.141592653589793,
            "angle_max": 3.141592653589793,
            "angle_increment": 0.008726646259971648,
            "time_increment": 0.0,
            "scan_time": 0.1,
            "range_min": 0.1,
            "range_max": 30.0,
            "ranges": "@RANGES@",
            "intensities": [],
        }
        text = orjson.dumps({"op": "publish", "topic": topic, "msg": msg})
        self.prefix, rest = text.split(b'"seq":0', 1)
        self.prefix += b'"seq":'
        self.mid, self.suffix = rest.split(b'"@RANGES@"', 1)

    def frame(self, seq: int) -> bytes:
        return b"".join(
            (
                self.prefix,
                str(seq).encode(),
                self.mid,
                self.ranges[seq % len(self.ranges)],
                self.suffix,
            )
        )


def verify_scan_samples(clients: list[RawWs], topic: str, count: int) -> tuple[int, int, int]:
    """Decode the kept samples: (checked, bad, frame_size of one verified sample)."""
    checked = bad = size = 0
    for c in clients:
        last_seq = -1
        for payload in c.samples:
            checked += 1
            try:
                op = orjson.loads(payload)
                seq = op["msg"]["header"]["seq"]
                ok = (
                    op["op"] == "publish"
                    and op["topic"] == topic
                    and len(op["msg"]["ranges"]) == 720
                    and 0 <= seq < count
                    and seq > last_seq
                )
                last_seq = seq
            except Exception:
                ok = False
            bad += not ok
            size = size or len(payload)
    return checked, bad, size


async def fanout_run(
    port: int, server: ServerProc, n_clients: int, count: int, src: ScanSource, topic: str, cfg
) -> dict:
    subs = []
    for k in range(0, n_clients, 25):  # connect in small batches
        subs += await asyncio.gather(
            *(
                RawWs.open(port, sample_every=max(count // 10, 1))
                for _ in range(min(25, n_clients - k))
            )
        )
    pub = await RawWs.open(port)
    pub.send({"op": "advertise", "topic": topic, "type": "sensor_msgs/LaserScan"})
    for s in subs:
        s.send({"op": "subscribe", "topic": topic, "type": "sensor_msgs/LaserScan"})
    await warm_up(pub, src, subs, lambda s: s.count)

    with CpuMeter(server) as cpu:
        t0 = perf()
        sent = 0
        stop_at = t0 + cfg.fanout_seconds
        while sent < count and perf() < stop_at:  # as fast as the server takes them
            pub.write_frame(ws_frame(src.frame(sent)))
            sent += 1
            await pub.drain()
        t_sent = perf()
        expected = sent * n_clients
        last_total, last_change = -1, perf()
        hard = t_sent + cfg.fanout_timeout
        while perf() < hard:
            total = sum(s.count for s in subs)
            if total >= expected:
                break
            if total != last_total:
                last_total, last_change = total, perf()
            elif perf() - last_change > 2.0 and perf() > t_sent:
                break  # no progress for 2 s: the rest was dropped
            await asyncio.sleep(0.01)
        t_end = max(s.last_rx for s in subs)
    elapsed = t_end - t0
    counts = [s.count for s in subs]
    total = sum(counts)
    nbytes = sum(s.nbytes for s in subs)
    checked, bad, _ = verify_scan_samples(subs, topic, 10**9)
    await close_all([pub, *subs])
    ok = elapsed > 0
    return {
        "clients": n_clients,
        "count": sent,
        "expected": expected,
        "total": total,
        "min": min(counts),
        "max": max(counts),
        "elapsed": elapsed,
        "rate": total / elapsed if ok else float("nan"),
        "per_client": total / elapsed / n_clients if ok else float("nan"),
        "mbps": nbytes / elapsed / 1e6 if ok else float("nan"),
        "frame": nbytes / total if total else float("nan"),
        "checked": checked,
        "bad": bad,
        "cpu": cpu.pcts(elapsed),
        "srv_us": 1e6 * cpu.server_s / total if total else float("nan"),
    }


def fanout_table(title: str, runs: list[dict]) -> None:
    print(title)
    rows = []
    for r in runs:
        rows.append(
            [
                r["clients"],
                f"{r['count']:,}",
                f"{r['total']:,}/{r['expected']:,}",
                f"{r['min']:,}-{r['max']:,}",
                f"{r['expected'] - r['total']:,}",
                f"{r['elapsed']:.2f}",
                fnum(r["rate"]),
                r["range"],
                fnum(r["per_client"]),
                fnum(r["mbps"], 1),
                f"{r['checked'] - r['bad']}/{r['checked']}",
                *r["cpu"],
                f"{r['srv_us']:.1f}",
            ]
        )
    print(
        table(
            [
                "clients",
                "msgs",
                "recv/expected",
                "per client",
                "dropped",
                "s",
                "msg/s total",
                "range of runs",
                "msg/s/client",
                "MB/s",
                "samples ok",
                "srv CPU",
                "cli CPU",
                "srv us/msg",
            ],
            rows,
        )
    )


class Variant:
    """One server under test in section 2/4: ours (with ``extra`` flags, from ``tree``) or the
    ceiling."""

    def __init__(self, label: str, ceiling: bool = False, extra: tuple = (),
                 tree: str | None = None):
        self.label, self.ceiling, self.extra, self.tree = label, ceiling, tuple(extra), tree

    def start(self, cfg, tag: str) -> ServerProc:
        if self.ceiling:
            return start_ceiling()
        return start_ours(cfg.profile, f"{tag}_{self.label}", self.extra, self.tree)


async def fanout_section(variants: list[Variant], cfg) -> dict[str, list[dict]]:
    """Each client count ``cfg.fanout_reps`` times per variant, each run on a fresh server, the
    variants interleaved (a, b, ..., a, b, ...: a busy machine's load falls on all alike); the
    median run of each is kept."""
    out: dict[str, list[dict]] = {v.label: [] for v in variants}
    for n in cfg.clients:
        topic = f"/bench/scan_{n}"
        src = ScanSource(topic)
        reps: dict[str, list[dict]] = {v.label: [] for v in variants}
        for rep in range(cfg.fanout_reps):
            for v in variants:
                server = v.start(cfg, f"fanout_{n}_{rep}")
                try:
                    reps[v.label].append(await fanout_run(
                        server.port, server, n, cfg.scan_counts[n], src, topic, cfg))
                finally:
                    server.stop()
        for v in variants:
            runs = sorted(reps[v.label], key=lambda r: r["rate"])
            run = dict(runs[len(runs) // 2])
            run["range"] = (f"{fnum(runs[0]['rate'])}-{fnum(runs[-1]['rate'])}"
                            if len(runs) > 1 else "-")
            run["total_all"] = sum(r["total"] for r in runs)
            run["expected_all"] = sum(r["expected"] for r in runs)
            out[v.label].append(run)
    return out


def ceiling_ratios(label: str, ours: list[dict], ceiling: list[dict]) -> list[str]:
    """Prints ``label``'s delivered rate and server CPU per message against the ceiling's;
    returns summary lines."""
    rows, lines = [], []
    for o, c in zip(ours, ceiling, strict=True):
        ratio = o["rate"] / c["rate"] if c["rate"] else float("nan")
        cpu_ratio = c["srv_us"] / o["srv_us"] if o["srv_us"] else float("nan")
        rows.append([o["clients"], fnum(o["rate"]), fnum(c["rate"]), f"{ratio:.2f}",
                     f"{o['srv_us']:.1f}", f"{c['srv_us']:.1f}", f"{cpu_ratio:.2f}",
                     f"{o['frame']:.0f}", f"{c['frame']:.0f}"])
        lines.append(f"{label}/ceiling {o['clients']:>2} clients: {ratio:.2f} "
                     f"({fnum(o['rate'])} vs {fnum(c['rate'])} msg/s); server CPU per message "
                     f"{o['srv_us']:.1f} vs {c['srv_us']:.1f} us, ratio {cpu_ratio:.2f}")
    print(f"\n  {label} vs ceiling (delivered msg/s, all clients)")
    print(table(["clients", label, "ceiling", "ratio", f"{label} srv us/msg",
                 "ceiling srv us/msg", "CPU ratio", f"{label} frame B", "ceiling frame B"],
                rows))
    print("  CPU ratio = ceiling's server CPU per delivered message / ours: the same "
          "comparison, less\n  sensitive to other load on the machine than the rate.")
    return lines


def compare_table(base: str, other: str, a: list[dict], b: list[dict]) -> list[str]:
    """Prints ``other``'s delivered rate against ``base``'s (same run, interleaved); returns
    summary lines."""
    rows, lines = [], []
    for x, y in zip(a, b, strict=True):
        ratio = y["rate"] / x["rate"] if x["rate"] else float("nan")
        rows.append([x["clients"], fnum(x["rate"]), fnum(y["rate"]), f"{ratio:.2f}",
                     f"{x['total_all']:,}/{x['expected_all']:,}",
                     f"{y['total_all']:,}/{y['expected_all']:,}",
                     f"{x['srv_us']:.1f}", f"{y['srv_us']:.1f}"])
        lines.append(f"{other} vs {base}, {x['clients']:>2} clients: {ratio:.2f} "
                     f"({fnum(y['rate'])} vs {fnum(x['rate'])} msg/s; received "
                     f"{y['total_all']:,}/{y['expected_all']:,} vs "
                     f"{x['total_all']:,}/{x['expected_all']:,})")
    print(f"\n  {other} vs {base} (delivered msg/s, all clients; runs interleaved)")
    print(table(["clients", base, other, "ratio", f"{base} received", f"{other} received",
                 f"{base} us/msg", f"{other} us/msg"], rows))
    return lines


# ======================================================================= 3. big map
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
    live.send(
        {
            "op": "subscribe",
            "topic": topic,
            "type": "nav_msgs/OccupancyGrid",
            "compression": compression,
        }
    )
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
    sub_op = orjson.dumps(
        {
            "op": "subscribe",
            "topic": topic,
            "type": "nav_msgs/OccupancyGrid",
            "compression": compression,
        }
    )
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


async def map_stall(port: int, grid: dict, compression: str, timeout: float) -> dict:
    """How long the server stops serving other clients while it handles one big map: a probe
    client ping-pongs small messages through the server (1 in flight) while the map is
    published to a subscriber that only counts frames (no client-side decoding here, so this
    process's event loop stays free and the probe RTTs are the server's)."""
    topic = f"/bench/map_stall_{compression}"
    pub_frame = ws_frame(orjson.dumps({"op": "publish", "topic": topic, "msg": grid}))
    loop = asyncio.get_running_loop()
    pending: dict[int, asyncio.Future] = {}

    def on_probe(payload: bytes, now: float) -> None:
        i = payload.find(b'"data":"')
        if i >= 0:
            fut = pending.pop(int(payload[i + 8 : payload.find(b'"', i + 8)]), None)
            if fut is not None and not fut.done():
                fut.set_result(now)

    pub = await RawWs.open(port)
    sub = await RawWs.open(port)
    probe = await RawWs.open(port, on_message=on_probe)
    pub.send({"op": "advertise", "topic": topic, "type": "nav_msgs/OccupancyGrid", "latch": True})
    sub.send(
        {
            "op": "subscribe",
            "topic": topic,
            "type": "nav_msgs/OccupancyGrid",
            "compression": compression,
        }
    )
    probe.send({"op": "advertise", "topic": "/bench/probe", "type": "std_msgs/String"})
    probe.send({"op": "subscribe", "topic": "/bench/probe", "type": "std_msgs/String"})
    for c in (pub, sub, probe):
        await barrier(c, "stall")
    sub.reset()
    rtts: list[tuple[float, float]] = []
    done = asyncio.Event()

    async def pinger() -> None:
        seq = 0
        end = perf() + timeout
        while not done.is_set() and perf() < end:
            seq += 1
            fut = pending[seq] = loop.create_future()
            start = perf()
            probe.send(b'{"op":"publish","topic":"/bench/probe","msg":{"data":"%d"}}' % seq)
            try:
                rtts.append((start, await asyncio.wait_for(fut, 10) - start))
            except TimeoutError:
                pending.pop(seq, None)
            await asyncio.sleep(0.001)

    task = asyncio.create_task(pinger())
    await asyncio.sleep(0.3)
    t0 = perf()
    pub.write_frame(pub_frame)
    end = t0 + timeout
    while sub.count == 0 and perf() < end:
        await asyncio.sleep(0.002)
    await asyncio.sleep(0.2)
    done.set()
    await task
    await close_all([pub, sub, probe])
    before = [r for t, r in rtts if t < t0]
    during = [r for t, r in rtts if t >= t0 - 0.05]
    return {
        "base": pct(before, 50) * 1e3,
        "max": max(during, default=float("nan")) * 1e3,
        "n": len(rtts),
    }


async def map_section(cfg) -> list[dict]:
    w = h = cfg.map_size
    grid = make_grid(w, h)
    results = []
    server = start_ours(cfg.profile, "map")
    try:
        for compression in ("none", "png"):  # untimed warm-up: first-touch memory costs
            await map_once(
                server.port,
                server,
                grid,
                f"/bench/map_warm_{compression}",
                compression,
                cfg.map_timeout,
            )
        for compression in ("none", "png"):
            for rep in range(cfg.map_reps):
                r = await map_once(
                    server.port,
                    server,
                    grid,
                    f"/bench/map_{compression}_{rep}",
                    compression,
                    cfg.map_timeout,
                )
                r["rep"] = rep
                results.append(r)
        stalls = {
            c: await map_stall(server.port, grid, c, cfg.map_timeout) for c in ("none", "png")
        }
        rss = server.rss_mb()
    finally:
        server.stop()
    print(
        f"\n[3] map: {w}x{h} nav_msgs/OccupancyGrid, latched, published by a client "
        f"(publish frame {results[0]['up'] / 1e6:.1f} MB)"
    )
    rows = []
    for r in results:
        rows.append(
            [
                r["compression"],
                r["rep"] + 1,
                f"{r['wire'] / 1e6:.2f}",
                fnum(r["first"], 1),
                fnum(r["frame"], 1),
                fnum(r["decode"], 1),
                fnum(r["total"], 1),
                f"{r['cpu']:.2f}",
                fnum(r["late_frame"], 1),
                fnum(r["late_total"], 1),
                "yes" if r["ok"] else "NO",
            ]
        )
    print(
        table(
            [
                "compression",
                "run",
                "wire MB",
                "1st byte ms",
                "frame ms",
                "decode ms",
                "publish->decoded ms",
                "srv CPU s",
                "late: frame ms",
                "late: decoded ms",
                "data ok",
            ],
            rows,
        )
    )
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
    for r in results:
        r["stall"] = stalls[r["compression"]]["max"]
    return results


# ======================================================================= 5. probe while maps
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


async def probe_maps_section(cfg) -> list[dict]:
    """Issue 11's scenario: a client calls /rosapi/get_time every 5 ms while another publishes
    big maps to one png and one uncompressed subscriber; probe RTT before and during."""
    server = start_ours(cfg.profile, "probe_maps")
    results = []
    try:
        port = server.port
        pub = await RawWs.open(port)
        subs = {c: await RawWs.open(port) for c in ("none", "png")}
        for size in cfg.probe_map_sizes:
            grid = make_grid(size, size)
            data = grid["data"]
            topic = f"/bench/probe_map_{size}"
            pub.send(
                {"op": "advertise", "topic": topic, "type": "nav_msgs/OccupancyGrid", "latch": True}
            )
            for comp, sub in subs.items():
                sub.send(
                    {
                        "op": "subscribe",
                        "topic": topic,
                        "type": "nav_msgs/OccupancyGrid",
                        "compression": comp,
                    }
                )
            for c in (pub, *subs.values()):
                await barrier(c, "probe-maps")
            frame = ws_frame(orjson.dumps({"op": "publish", "topic": topic, "msg": grid}))
            del grid

            async def publish_once(frame=frame, data=data) -> dict:
                got = {c: asyncio.get_running_loop().create_future() for c in subs}
                for comp, sub in subs.items():

                    def on_msg(payload, now, comp=comp):
                        if payload.startswith(b'{"op":"status"') or b"service_resp" in payload[:40]:
                            return
                        if not got[comp].done():
                            got[comp].set_result((payload, now))

                    sub.on_message = on_msg
                t0 = perf()
                pub.write_frame(frame)
                out = {}
                for comp, fut in got.items():
                    payload, t_frame = await asyncio.wait_for(fut, cfg.map_timeout)
                    out[comp] = {"frame": (t_frame - t0) * 1e3, "payload": payload}
                for sub in subs.values():
                    sub.on_message = None
                return out

            def decode_runs(runs: list[dict], data=data) -> None:
                """After the probe window, so that this process's decoding (a core's worth on a
                2-core machine) does not starve the server and the probe during it."""
                for run in runs:
                    for comp, r in run.items():
                        t = perf()
                        msg = decode_map(r.pop("payload"), comp)
                        r["decoded"] = r["frame"] + (perf() - t) * 1e3
                        r["ok"] = msg["msg"]["data"] == data

            if size == cfg.probe_map_sizes[0]:
                await publish_once()  # untimed warm-up: starts the server's worker pool
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
                runs = [await publish_once() for _ in range(cfg.probe_map_reps)]
                t1 = time.monotonic()
                await asyncio.sleep(0.2)
            finally:
                out, _ = await asyncio.to_thread(probe.communicate, "", 30)
            decode_runs(runs)
            rtts = orjson.loads(out.strip().splitlines()[-1])
            before = [r for t, r in rtts if t < t0]
            during = [r for t, r in rtts if t0 <= t <= t1]
            results.append(
                {
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
                    "ok": all(r[c]["ok"] for r in runs for c in subs),
                }
            )
        await close_all([pub, *subs.values()])
        rss = server.rss_mb()
    finally:
        server.stop()
    print(
        "\n[5] probe while maps: a client calls /rosapi/get_time every 5 ms (its own process) "
        "while another publishes\n    OccupancyGrid maps on a latched topic to one png and one "
        "uncompressed subscriber, one map after the other"
    )
    print(
        table(
            [
                "map",
                "publish MB",
                "maps",
                "probe p50 before ms",
                "probe p50 during ms",
                "probe max during ms",
                "probes",
                "none: publish->decoded ms",
                "png: publish->decoded ms",
                "data ok",
            ],
            [
                [
                    f"{r['size']}x{r['size']}",
                    f"{r['frame_mb']:.1f}",
                    r["maps"],
                    f"{r['base_p50']:.2f}",
                    f"{r['p50']:.2f}",
                    fnum(r["max"], 1),
                    r["n"],
                    fnum(r["none"]),
                    f"{fnum(r['png'])} (max {fnum(r['png_max'])})",
                    "yes" if r["ok"] else "NO",
                ]
                for r in results
            ],
        )
    )
    print(
        "  publish->decoded: best of the maps = frame received + client decode (timed after the "
        "probe window, so the\n  bench's decoding does not compete with the server for the 2 "
        f"cores during it). Server peak RSS "
        f"{rss:.0f} MB (main process + worker pool peaks; the pool's CPU is not counted)."
    )
    return results


# ======================================================================= 6. memory
async def idle_rss(cfg) -> dict:
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


async def stalled_rss(cfg) -> dict:
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


async def memory_section(cfg) -> dict:
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


# ======================================================================= main
def machine_info() -> None:
    import PIL
    import websockets

    model = ""
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    try:
        from hitrobot_server import __version__ as ours
    except Exception:
        ours = "?"
    print(
        f"machine: {os.cpu_count()} cores ({model or platform.machine()}), "
        f"{platform.system()} {platform.release()}"
    )
    print(
        f"python {platform.python_version()} ({platform.python_implementation()}), "
        f"websockets {websockets.__version__}, orjson {orjson.__version__}, "
        f"numpy {np.__version__}, pillow {PIL.__version__}, hitrobot-server {ours}"
    )
    print(
        "setup: loopback 127.0.0.1, ephemeral ports; each server (ours and the ceiling) runs "
        "in its OWN process, the\n       measuring clients in this one (asyncio, raw "
        "header-parsing WS clients) - client and server do not share\n       an event loop "
        "or a core's loop. srv/cli CPU = CPU time / wall time of the measured window "
        "(100% = one core)."
    )


def config(quick: bool):
    class C:
        pass

    c = C()
    c.quick = quick
    c.windows = (16, 128)  # in-flight limits; window 1 is the ping-pong run
    c.relay_count = 30_000 if quick else 150_000
    c.relay_seconds = 1.5 if quick else 5.0
    c.ping_count = 3_000 if quick else 10_000
    c.ping_seconds = 1.0 if quick else 3.0
    # LaserScan messages per run, per client count (more for fewer clients, so that every run
    # lasts long enough to time; the ceiling runs use the same counts)
    c.scan_counts = {1: 12_000, 10: 3_000, 50: 800} if quick else {1: 30_000, 10: 8_000, 50: 2_000}
    c.fanout_seconds = 3.0 if quick else 6.0  # the publisher stops after this, whatever the count
    c.fanout_reps = 1 if quick else 3
    c.clients = (1, 10, 50)
    c.fanout_timeout = 15.0  # after the last publish
    c.map_size = 2000
    c.map_reps = 1 if quick else 3
    c.map_timeout = 60.0
    c.probe_map_sizes = (2000, 4000)
    c.probe_map_reps = 2 if quick else 4
    c.idle_clients = 1000
    c.stall_seconds = 10.0 if quick else 30.0
    c.stall_rate = 500  # LaserScans per second
    return c


async def run(cfg, sections: set[str]) -> None:
    summary = []
    t_start = perf()
    machine_info()
    print(
        f"mode: {'--quick' if cfg.quick else 'full'}"
        + (
            f"; hitrobot-server runs under cProfile (slower!), profiles in {cfg.profile}/"
            if cfg.profile
            else ""
        )
    )

    if "1" in sections:
        server = start_ours(cfg.profile, "relay")
        try:
            r1 = await relay_section(server.port, server, cfg)
        finally:
            server.stop()
        summary.append(
            f"relay String 1->1: {fnum(r1['rate'])} msg/s (window {r1['window']}); "
            f"ping-pong p50 {r1['ping_p50']:.3f} ms, p99 {r1['ping_p99']:.3f} ms"
        )

    variants = []
    if "2" in sections:
        variants.append(Variant("ours"))
        if cfg.compare is not None:
            variants.append(Variant(cfg.compare_label, extra=cfg.compare,
                                    tree=cfg.compare_tree))
    if "4" in sections:
        variants.append(Variant("ceiling", ceiling=True))
    runs = await fanout_section(variants, cfg) if variants else {}
    ours = runs.get("ours")
    if ours:
        size = ours[0]["frame"]
        for v in variants:
            if v.ceiling:
                continue
            fanout_table(
                f"\n[2] fan-out: sensor_msgs/LaserScan, 720 float ranges (~{size / 1e3:.1f} "
                f"kB frames) published at max rate, hitrobot-server ({v.label})",
                runs[v.label],
            )
        print(
            "  msg/s = frames received by all clients / (last frame received - first publish "
            "sent); MB/s = payload bytes, all clients.\n  dropped = expected - received (a "
            "slow client loses its oldest topic data by design); per client = min-max "
            "received.\n  "
            + (
                f"median of {cfg.fanout_reps} runs, each on a fresh server "
                "process; 'range of runs' = slowest-fastest."
                if cfg.fanout_reps > 1
                else "one run per client count."
            )
        )
        for r in ours:
            summary.append(
                f"fan-out {r['clients']:>2} clients: {fnum(r['rate'])} msg/s total, "
                f"{fnum(r['per_client'])}/client, {fnum(r['mbps'], 1)} MB/s, "
                f"received {r['total_all']:,}/{r['expected_all']:,} (all runs)"
            )
        if cfg.compare is not None:
            summary += compare_table("ours", cfg.compare_label, ours, runs[cfg.compare_label])

    ceiling = runs.get("ceiling")
    if ceiling:
        fanout_table(
            "\n[4] ceiling: the same LaserScan frames and counts, bare websockets server "
            "(broadcast() of the received\n    pre-encoded bytes, no parsing)",
            ceiling,
        )
        for v in variants:
            if not v.ceiling:
                summary += ceiling_ratios(v.label, runs[v.label], ceiling)

    if "3" in sections:
        maps = await map_section(cfg)
        for comp in ("none", "png"):
            rs = [r for r in maps if r["compression"] == comp]
            best = min(rs, key=lambda r: r["total"])
            summary.append(
                f"map {cfg.map_size}x{cfg.map_size} {comp:>4}: publish->decoded "
                f"{fnum(best['total'])} ms (best of {len(rs)}), wire "
                f"{best['wire'] / 1e6:.2f} MB, late joiner {fnum(best['late_total'])}"
                f" ms; other clients stalled up to {fnum(best['stall'])} ms"
            )

    if "5" in sections:
        for r in await probe_maps_section(cfg):
            summary.append(
                f"probe RTT during {r['size']}x{r['size']} maps: p50 {r['p50']:.2f} ms, max "
                f"{fnum(r['max'], 1)} ms (before: p50 {r['base_p50']:.2f}); png publish->decoded "
                f"{fnum(r['png'])} ms, none {fnum(r['none'])} ms"
            )

    if "6" in sections:
        mem = await memory_section(cfg)
        idle, stall = mem["idle"], mem["stall"]
        summary.append(
            f"{idle['clients']} idle clients: +{idle['full'] - idle['empty']:.1f} MB RSS; stalled "
            f"reader over {stall['seconds']:.0f} s: RSS {stall['rss'][0]:.0f} -> max "
            f"{max(stall['rss']):.0f} MB"
        )

    print("\n== summary " + "=" * 60)
    for line in summary:
        print("  " + line)
    print(f"  total bench time {perf() - t_start:.1f} s")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a ~20 s run with smaller counts")
    parser.add_argument(
        "--sections", default="123456", help="which sections to run, e.g. 24 (default: all)"
    )
    parser.add_argument(
        "--profile-server",
        metavar="DIR",
        help="run each hitrobot-server under cProfile, writing DIR/<run>.prof",
    )
    parser.add_argument(
        "--server-args",
        default="",
        metavar="ARGS",
        help="more flags for each hitrobot-server, e.g. '--event-loop asyncio'",
    )
    parser.add_argument(
        "--record",
        action="store_true",
        help="run every hitrobot-server with --record (into a temporary folder), to compare "
        "the figures with and without recording",
    )
    parser.add_argument(
        "--compare",
        metavar="ARGS",
        help="sections 2/4: also run a second hitrobot-server with these extra flags (e.g. "
        "'--no-send-window'), interleaved with the first, and print the two side by side",
    )
    parser.add_argument(
        "--compare-tree",
        metavar="DIR",
        help="sections 2/4: the second server runs from this source tree (e.g. a checkout of "
        "main: before/after in one run); with or without --compare",
    )
    parser.add_argument("--clients", default="1,10,50",
                        help="section 2/4 subscriber counts, e.g. 1 (default 1,10,50)")
    parser.add_argument("--ceiling-lib", choices=("websockets", "picows"), default="websockets",
                        help="section 4's bare server: websockets (ours is built on it) or "
                        "picows (pip install picows; what a faster WebSocket layer gives)")
    parser.add_argument("--ceiling-server", metavar="LIB", help=argparse.SUPPRESS)
    parser.add_argument("--probe-client", type=int, metavar="PORT", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.ceiling_server:
        (picows_ceiling_main if args.ceiling_server == "picows" else ceiling_server_main)()
        return 0
    CEILING_LIB[0] = args.ceiling_lib
    if args.probe_client:
        probe_client_main(args.probe_client, limit=300.0)
        return 0
    with contextlib.suppress(ValueError, OSError):  # 1000 idle clients need the file handles
        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, min(hard, 8192)), hard))
    cfg = config(args.quick)
    cfg.profile = args.profile_server
    cfg.clients = tuple(int(n) for n in args.clients.split(","))
    cfg.compare = (shlex.split(args.compare or "")
                   if args.compare is not None or args.compare_tree else None)
    cfg.compare_tree = args.compare_tree
    cfg.compare_label = " ".join(
        ([f"tree {Path(args.compare_tree).name}"] if args.compare_tree else [])
        + (cfg.compare or [])) or "other"
    SERVER_ARGS.extend(shlex.split(args.server_args))
    global RECORD_DIR
    with tempfile.TemporaryDirectory(prefix="bench-record-") as folder:
        RECORD_DIR = folder if args.record else None
        if args.record:
            print(f"every server records (--record) into {folder}")
        asyncio.run(run(cfg, set(args.sections)))
    return 0


if __name__ == "__main__":
    sys.exit(main())

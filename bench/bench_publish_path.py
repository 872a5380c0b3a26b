#!/usr/bin/env python3
"""Where the CPU of one relayed LaserScan goes at one subscriber (issue 38 item 3).

In one process, without sockets: a real server's rosbridge sessions (a publisher and a
subscriber whose outbox writes into a list), fed benchlib's pre-encoded LaserScan publish
frames. Each stage of the publish path is timed on its own (CPU time per message, many
repetitions), then the whole ``receive``. What is left beyond the stages is the transport's
share (websockets' parsing and framing, the syscalls), which bench_ceiling.py
measures against a bare websockets server. With msgspec installed, a typed decoder of the same
frame is timed too (the alternative to orjson + today's validator). No assertions.

    .venv/bin/python bench/bench_publish_path.py [--count 5000]
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import orjson

sys.path.insert(0, str(Path(__file__).resolve().parent))
from benchlib import HOST, ScanSource, table  # noqa: E402

from hitrobot_server.config import Settings  # noqa: E402
from hitrobot_server.protocol import ops  # noqa: E402
from hitrobot_server.server import HitrobotServer  # noqa: E402
from hitrobot_server.session.rosbridge.encodings import seeded  # noqa: E402
from hitrobot_server.session.rosbridge.verbatim import verbatim_publish  # noqa: E402
from hitrobot_server.types import jsoncodec  # noqa: E402
from hitrobot_server.types.convert import from_json_verbatim  # noqa: E402

TOPIC = "/bench/scan"


def cpu_us(fn: Callable[[], object], count: int) -> float:
    """CPU microseconds per call of ``fn`` (the best of three runs of ``count`` calls)."""
    best = float("inf")
    for _ in range(3):
        t0 = time.process_time()
        for _ in range(count):
            fn()
        best = min(best, (time.process_time() - t0) / count * 1e6)
    return best


def msgspec_decoder():
    """A typed msgspec decoder of the LaserScan publish op, or None without msgspec."""
    try:
        import msgspec
    except ImportError:
        return None

    def struct(name: str, fields: list) -> type:
        return msgspec.defstruct(name, fields, forbid_unknown_fields=True)

    stamp = struct("Time", [("secs", int), ("nsecs", int)])
    header = struct("Header", [("seq", int), ("stamp", stamp), ("frame_id", str)])
    scan = struct("LaserScan", [("header", header)] + [
        (name, float) for name in ("angle_min", "angle_max", "angle_increment",
                                   "time_increment", "scan_time", "range_min", "range_max")
    ] + [("ranges", list[float]), ("intensities", list[float])])
    publish = msgspec.defstruct("Publish", [("op", str), ("topic", str), ("msg", scan)])
    return msgspec.json.Decoder(publish)


async def measure(count: int) -> list[list[str]]:
    with tempfile.TemporaryDirectory(prefix="bench-path-") as state:
        server = HitrobotServer(Settings.of(port=0, tcp_port=0, address=HOST, robot="none",
                                            state_dir=state))
        await server.start()
        try:
            return stages(server, count)
        finally:
            await server.stop()


def stages(server: HitrobotServer, count: int) -> list[list[str]]:
    src = ScanSource(TOPIC)
    frames = [src.frame(i).decode() for i in range(64)]
    pub = server.protocols.open(HOST, None)
    sub = server.protocols.open(HOST, None)
    out: list = []
    sub.outbox.attach_writer(lambda written: out.append(written) or True)
    pub.outbox.attach_writer(lambda written: True)
    pub.receive(orjson.dumps({"op": "advertise", "topic": TOPIC,
                              "type": "sensor_msgs/LaserScan"}).decode())
    sub.receive(orjson.dumps({"op": "subscribe", "topic": TOPIC,
                              "type": "sensor_msgs/LaserScan"}).decode())
    frame = frames[0]
    obj = orjson.loads(frame)
    op = ops.validate_op(ops.parse_message(obj))
    mtype = server.bus.topic(TOPIC).mtype
    value = from_json_verbatim(mtype, obj["msg"], server.bus.types)[0]
    text = verbatim_publish(frame, op.raw)
    seq = iter(range(10**12))

    def whole() -> None:
        pub.receive(frames[next(seq) & 63])
        if len(out) > 1000:
            out.clear()

    def bus_publish() -> None:
        server.bus.publish(TOPIC, value, origin=pub.origin, seed=seeded(len(frame), TOPIC, text))
        if len(out) > 1000:
            out.clear()

    def same() -> None:
        pub.receive(frame)
        if len(out) > 1000:
            out.clear()

    def parse_and_convert() -> None:
        parsed = jsoncodec.loads(frames[next(seq) & 63])
        from_json_verbatim(mtype, parsed["msg"], server.bus.types)

    rows = [
        ("session.receive, all of it (no socket)", whole),
        ("session.receive, the same frame each time", same),
        ("  loads + from_json_verbatim of a new frame each time", parse_and_convert),
        ("  jsoncodec.loads (orjson, then a lenient fallback)", lambda: jsoncodec.loads(frame)),
        ("  parse_message + validate_op", lambda: ops.validate_op(ops.parse_message(obj))),
        ("  from_json_verbatim (the typed check, canonical dict)",
         lambda: from_json_verbatim(mtype, obj["msg"], server.bus.types)),
        ("  verbatim_publish (the client's text as the outgoing op)",
         lambda: verbatim_publish(frame, op.raw)),
        ("  bus.publish + fan-out + frames + outbox + direct write", bus_publish),
    ]
    decoder = msgspec_decoder()
    if decoder is not None:
        data = frame.encode()
        rows.append(("  (alternative) msgspec typed decode of the frame",
                     lambda: decoder.decode(data)))
    return [[name, f"{cpu_us(fn, count):.1f}"] for name, fn in rows]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=5000, help="calls per timing")
    args = parser.parse_args()
    rows = asyncio.run(measure(args.count))
    print("LaserScan publish (720 ranges, ~13.7 kB), one subscriber, CPU us per message")
    print(table(["stage", "us"], rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What recording every topic costs the fan-out (issue 33, item 7): the same LaserScan fan-out as
``bench_bridge.py`` section 2, to 1, 10 and 50 subscribers, on a server without recording and
on one with ``--record`` (every topic), run side by side (interleaved, a fresh server each run)
in one process, and the ratio recorded / not recorded of delivered msg/s and of server CPU per
delivered message. Prints figures only (no assertions).

    .venv/bin/python bench/bench_record.py            # 3 rounds per client count
    .venv/bin/python bench/bench_record.py --quick    # 1 round, smaller counts

``--paired`` runs one server per client count instead, with the publisher never stopping, and
turns recording on and off through the console's own services (``/record/start``,
``/record/stop``, every topic, into ``--record-dir``) in segments: each pair is a recorded and a
plain segment next to each other (the order alternating), measured after the writer has
started, so a slow phase of the machine hits both sides of a pair alike. It prints the ratio
per pair and its median, the scans in the files against those the publisher wrote while
recording (approximate: frames in flight at start and stop), and what the recorder dropped (its
``/record/stop`` reply).

``--loop`` measures instead, in this process, what the recorder's tap costs the event loop's
process per message: the CPU time (every thread of the process; the batches are written down
the pipe by the loop itself) of publishing client LaserScans (a rosbridge publish's own JSON
text, as the bus carries it) with a recorder tapping the bus, minus the same without one; and
the writer process's CPU per message. Run it with another tree first on ``PYTHONPATH`` to
measure that tree's recorder.

Each round runs both servers for each client count (the order alternates between rounds, so a
background load hits both alike). ``srv us/msg`` is the server process's CPU per delivered
message (the event loop's process); the recorder's writer process is measured apart
(``writer CPU``, seconds over the run, warm-up included, its own start excluded; ``writer
us/msg``, that per LaserScan in the file: the writer's CPU per message). After
each recorded run the file is read back with the ``mcap`` reader and its LaserScans counted
(``recorded``: what reached the file of what was published).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import os
import re
import shlex
import statistics
import sys
import tempfile
import time
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader

sys.path.insert(0, str(Path(__file__).resolve().parent))
import benchlib as bb  # noqa: E402
from bench_fanout import fanout_run  # noqa: E402
from bench_workers import cpu_seconds  # noqa: E402
from wsclient import RawWs, close_all, warm_up, ws_frame  # noqa: E402

from hitrobot_server import procmem  # noqa: E402


def recorded_count(folder: Path, topic: str) -> int:
    """LaserScans of ``topic`` in every file of the folder (a split recording has several)."""
    total = 0
    for path in sorted(folder.glob("*.mcap")):
        try:
            with open(path, "rb") as f:
                summary = make_reader(f).get_summary()
        except McapError:  # empty or cut (a server killed before its writer finished)
            continue
        if summary is None or summary.statistics is None:
            continue
        ids = [i for i, c in summary.channels.items() if c.topic == topic]
        total += sum(summary.statistics.channel_message_counts.get(i, 0) for i in ids)
    return total


def children_cpu(server: bb.ServerProc) -> float:
    """CPU seconds of the server's recorder writer so far."""
    return cpu_seconds(writer_pids(server.proc.pid))


async def one_run(n: int, record: bool, cfg, folder: Path, tag: str) -> dict:
    topic = f"/bench/scan_{n}"
    src = bb.ScanSource(topic)
    out = folder / tag
    out.mkdir()
    bb.RECORD_DIR = str(out) if record else None
    server = bb.start_ours(None, tag)
    try:
        before = await writer_started(server.proc.pid) if record else 0.0
        run = await fanout_run(server.port, server, n, cfg.scan_counts[n], src, topic, cfg)
        run["writer_s"] = children_cpu(server) - before
    finally:
        server.stop()
        bb.RECORD_DIR = None
    run["recorded"] = recorded_count(out, topic) if record else None
    if record and run["recorded"] < run["count"]:  # say why: the server's last words
        print("".join(server.output[-8:]), end="", file=sys.stderr)
    run["writer_us"] = run["writer_s"] / run["recorded"] * 1e6 if run["recorded"] else 0.0
    return run


async def main_async(cfg, rounds: int) -> None:
    bb.machine_info()
    results: dict[tuple[int, bool], list[dict]] = {}
    with tempfile.TemporaryDirectory(prefix="bench-record-") as tmp:
        folder = Path(tmp)
        for r in range(rounds):
            for n in cfg.clients:
                order = (False, True) if (r + n) % 2 == 0 else (True, False)
                for record in order:
                    tag = f"r{r}_{n}_{'rec' if record else 'plain'}"
                    run = await one_run(n, record, cfg, folder, tag)
                    results.setdefault((n, record), []).append(run)
                    print(f"  round {r + 1} {n:>2} clients {'record' if record else 'plain ':6}: "
                          f"{bb.fnum(run['rate'])} msg/s, {run['srv_us']:.1f} us/msg server CPU, "
                          f"recv {run['total']:,}/{run['expected']:,}"
                          + (f", recorded {run['recorded']:,}/{run['count']:,}, writer CPU "
                             f"{run['writer_s']:.1f} s ({run['writer_us']:.0f} us/msg)"
                             if record else ""), flush=True)
    rows = []
    for n in cfg.clients:
        plain, rec = results[(n, False)], results[(n, True)]
        ratios = [b["rate"] / a["rate"] for a, b in zip(plain, rec, strict=True)]
        cpu = [b["srv_us"] / a["srv_us"] for a, b in zip(plain, rec, strict=True)]
        rows.append([
            n,
            bb.fnum(statistics.median(a["rate"] for a in plain)),
            bb.fnum(statistics.median(b["rate"] for b in rec)),
            " / ".join(f"{x:.2f}" for x in ratios),
            f"{statistics.median(ratios):.2f}",
            " / ".join(f"{x:.2f}" for x in cpu),
            ", ".join(f"{b['recorded']:,}/{b['count']:,}" for b in rec),
            " / ".join(f"{b['writer_s']:.1f}" for b in rec),
            " / ".join(f"{b['writer_us']:.0f}" for b in rec),
            " / ".join(f"{a['srv_us']:.0f}/{b['srv_us']:.0f}" for a, b in zip(plain, rec,
                                                                        strict=True)),
        ])
    print("\nLaserScan fan-out (720 ranges), recording every topic vs not, side by side")
    print(bb.table(["clients", "plain msg/s", "recorded msg/s", "ratio per round",
                    "median ratio", "srv us/msg ratio", "recorded/published",
                    "writer CPU s", "writer us/msg", "srv us/msg plain/rec"], rows))


async def call(client: RawWs, service: str, args: dict, timeout: float = 15.0) -> bytes:
    """A ``call_service`` from a bench client; its ``service_response`` (raw JSON)."""
    op_id = f"bench:{service}:{time.monotonic_ns()}".encode()
    got = asyncio.get_running_loop().create_future()

    def hook(payload: bytes, _now: float) -> None:
        if op_id in payload and b"service_response" in payload and not got.done():
            got.set_result(payload)

    client.on_message = hook
    try:
        client.send({"op": "call_service", "id": op_id.decode(), "service": service,
                     "args": args})
        return await asyncio.wait_for(got, timeout)
    finally:
        client.on_message = None


async def paired_run(n: int, pairs: int, seconds: float, folder: Path) -> dict:
    """One server, ``n`` subscribers, a publisher that never stops; ``pairs`` recorded and
    plain segments of ``seconds`` each, side by side (see the docstring)."""
    topic = f"/bench/scan_{n}"
    src = bb.ScanSource(topic)
    server = bb.start_ours(None, f"paired_{n}", ["--record-dir", str(folder)])
    subs = []
    try:
        for k in range(0, n, 25):
            subs += await asyncio.gather(*(RawWs.open(server.port)
                                           for _ in range(min(25, n - k))))
        pub = await RawWs.open(server.port)
        control = await RawWs.open(server.port)
        pub.send({"op": "advertise", "topic": topic, "type": "sensor_msgs/LaserScan"})
        for sub in subs:
            sub.send({"op": "subscribe", "topic": topic, "type": "sensor_msgs/LaserScan"})
        await warm_up(pub, src, subs, lambda sub: sub.count)
        sent = [0]
        running = [True]

        async def publish() -> None:
            while running[0]:  # as fast as the server takes them
                pub.write_frame(ws_frame(src.frame(sent[0])))
                sent[0] += 1
                await pub.drain()
                if sent[0] % 20 == 0:
                    await asyncio.sleep(0)

        async def segment() -> tuple[float, float]:
            """Delivered msg/s and server CPU µs per delivered message over ``seconds``."""
            c0, n0, t0 = server.cpu(), sum(sub.count for sub in subs), time.perf_counter()
            await asyncio.sleep(seconds)
            c1, n1, t1 = server.cpu(), sum(sub.count for sub in subs), time.perf_counter()
            got = max(n1 - n0, 1)
            return got / (t1 - t0), (c1 - c0) / got * 1e6

        task = asyncio.create_task(publish())
        plain, rec, while_recording, dropped = [], [], 0, 0
        try:
            await asyncio.sleep(1.0)
            for k in range(pairs):
                for recording in ((True, False) if k % 2 == 0 else (False, True)):
                    if recording:
                        reply = await call(control, "/record/start", {"name": f"seg{k}.mcap"})
                        assert b'"success":true' in reply.replace(b" ", b""), reply
                        first = sent[0]
                        await asyncio.sleep(RECORD_SETTLE)  # the writer process starts
                        rec.append(await segment())
                        reply = await call(control, "/record/stop", {})
                        while_recording += sent[0] - first
                        lost = re.search(rb"\((\d+) dropped\)", reply)
                        dropped += int(lost.group(1)) if lost else 0
                    else:
                        await asyncio.sleep(PLAIN_SETTLE)
                        plain.append(await segment())
        finally:
            running[0] = False
            await task
        await close_all([pub, control, *subs])
    finally:
        server.stop()
    for line in server.output:
        if "dropped" in line:
            print("   ", line.strip(), file=sys.stderr)
    return {"plain": plain, "rec": rec, "recorded": recorded_count(folder, topic),
            "while_recording": while_recording, "dropped": dropped}


RECORD_SETTLE = 2.5  # seconds from /record/start to a measured segment (the writer's spawn)
PLAIN_SETTLE = 1.0  # seconds from /record/stop (the writer finishing) to a plain segment


async def paired_main(clients: tuple[int, ...], pairs: int, seconds: float) -> None:
    bb.machine_info()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-record-paired-") as tmp:
        for n in clients:
            folder = Path(tmp) / f"c{n}"
            folder.mkdir()
            run = await paired_run(n, pairs, seconds, folder)
            ratios = [r[0] / p[0] for p, r in zip(run["plain"], run["rec"], strict=True)]
            added = [r[1] - p[1] for p, r in zip(run["plain"], run["rec"], strict=True)]
            print(f"  {n:>2} clients: ratio per pair {' / '.join(f'{x:.2f}' for x in ratios)}",
                  flush=True)
            rows.append([
                n,
                bb.fnum(statistics.median(p[0] for p in run["plain"])),
                bb.fnum(statistics.median(r[0] for r in run["rec"])),
                f"{statistics.median(ratios):.2f}",
                f"{min(ratios):.2f}-{max(ratios):.2f}",
                f"{statistics.median(added):+.1f}",
                f"{run['recorded']:,}/~{run['while_recording']:,}",
                f"{run['dropped']:,}",
            ])
    print(f"\nLaserScan fan-out, recording turned on and off in one server ({pairs} pairs of "
          f"{seconds:g} s segments)")
    print(bb.table(["clients", "plain msg/s", "recorded msg/s", "median ratio", "pair range",
                    "srv us/msg added", "in files/~published while recording",
                    "dropped by the recorder"], rows))


async def loop_cost(count: int, rounds: int) -> None:
    """CPU µs per published message with and without a recorder tap (see the docstring)."""

    import orjson

    from hitrobot_server.bus.core import Bus
    from hitrobot_server.record.recorder import Recorder
    from hitrobot_server.session.rosbridge.encodings import seeded
    from hitrobot_server.types.registry import TypeRegistry

    src = bb.ScanSource("/scan")
    ops = [src.frame(i) for i in range(64)]
    msgs = [orjson.loads(op)["msg"] for op in ops]

    async def publish_all(bus: Bus) -> float:
        t0 = time.process_time()
        for i in range(count):
            op = ops[i % 64]
            bus.publish("/scan", msgs[i % 64], seed=seeded(len(op), "/scan", op))
            if i % 50 == 49:
                await asyncio.sleep(0)  # the loop's timers run (the recorder's hand-off)
        return time.process_time() - t0

    plain, tapped, writer = [], [], []
    with tempfile.TemporaryDirectory(prefix="bench-record-loop-") as tmp:
        for r in range(rounds):
            bus = Bus(TypeRegistry.default())
            bus.advertise("/scan", "sensor_msgs/LaserScan", "bench", "/bench")
            plain.append(await publish_all(bus))
            children = children_rusage()
            recorder = Recorder(bus, Path(tmp) / f"loop_{r}.mcap", max_queued_bytes=2**31)
            recorder.start()
            started = await writer_started()
            t0 = time.process_time()
            await publish_all(bus)
            await recorder.stop()  # until the pipe has taken everything
            tapped.append(time.process_time() - t0)
            writer.append(children_rusage() - children - started)
            assert recorder.dropped == 0, recorder.dropped
            assert recorder.messages == count, (recorder.messages, count)
    per = [(b - a) / count * 1e6 for a, b in zip(plain, tapped, strict=True)]
    print(f"loop process CPU per recorded message ({count:,} LaserScans x {rounds} rounds): "
          f"publish alone {statistics.median(plain) / count * 1e6:.1f} us, "
          f"the recorder adds {' / '.join(f'{x:.1f}' for x in per)} us "
          f"(median {statistics.median(per):.1f} us)")
    per = [w / count * 1e6 for w in writer]
    print(f"writer process CPU per recorded message (its start excluded): "
          f"{' / '.join(f'{x:.1f}' for x in per)} us (median {statistics.median(per):.1f} us)")


def children_rusage() -> float:
    """CPU seconds of this process's children that have ended (the writers joined so far)."""
    import resource

    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def writer_pids(parent: int) -> list[int]:
    """The recorder's writer among ``parent``'s children (not multiprocessing's resource
    tracker, also a child)."""
    found = []
    for pid in procmem.children(parent):
        with contextlib.suppress(OSError):
            if b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes():
                found.append(pid)
    return found


async def writer_started(parent: int | None = None, timeout: float = 30.0) -> float:
    """The CPU seconds the writer process (a child of ``parent``, default this process) took
    to start: polled until it stops growing (it then waits for its first batch)."""

    def writers() -> list[int]:
        return writer_pids(os.getpid() if parent is None else parent)

    pids = writers()
    last, stable, deadline = -1.0, 0, time.monotonic() + timeout
    while stable < 3 and time.monotonic() < deadline:
        await asyncio.sleep(0.1)
        pids = pids or writers()
        now = cpu_seconds(pids)
        stable = stable + 1 if now == last and now > 0 else 0
        last = now
    return last


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="1 round, smaller counts")
    parser.add_argument("--rounds", type=int, default=None, help="rounds (default 3, quick 1)")
    parser.add_argument("--server-args", default="", metavar="ARGS",
                        help="more flags for each hitrobot-server")
    parser.add_argument("--clients", default="1,10,50", metavar="N,N",
                        help="subscriber counts (default 1,10,50)")
    parser.add_argument("--loop", action="store_true",
                        help="only the tap's CPU per message, in this process")
    parser.add_argument("--paired", action="store_true",
                        help="one server per client count, recording turned on and off")
    parser.add_argument("--pairs", type=int, default=6, help="--paired: pairs (default 6)")
    parser.add_argument("--seconds", type=float, default=2.0,
                        help="--paired: seconds a segment (default 2)")
    args = parser.parse_args()
    if args.paired:
        asyncio.run(paired_main(tuple(int(n) for n in args.clients.split(",")), args.pairs,
                                args.seconds))
        return 0
    if args.loop:
        asyncio.run(loop_cost(2000 if args.quick else 5000, args.rounds or 3))
        return 0
    cfg = bb.config(args.quick)
    cfg.clients = tuple(int(n) for n in args.clients.split(","))
    bb.SERVER_ARGS.extend(shlex.split(args.server_args))
    asyncio.run(main_async(cfg, args.rounds or (1 if args.quick else 3)))
    return 0


if __name__ == "__main__":
    sys.exit(main())

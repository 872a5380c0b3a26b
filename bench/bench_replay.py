"""Replay's memory and open time for recordings of 10 MB, 100 MB and 1 GB of messages.

Each recording is written with the mcap library's writer (zstd chunks of 1 MiB, as our recorder
writes them; messages of 256 KiB, a quarter of them random so a chunk compresses about 4:1),
then replayed in a child process of its own: ``load_recording`` (timed: the open), then a
:class:`Player` on a bus at speed 100 to the last message. The child prints its RSS after its
imports, after the open and at its peak (``ru_maxrss``). Prints figures, asserts nothing.

    .venv/bin/python bench/bench_replay.py                 # 10 MB, 100 MB, 1 GB
    .venv/bin/python bench/bench_replay.py --sizes 10 100  # MB of messages
    .venv/bin/python bench/bench_replay.py --against HEAD~1  # also the code of another commit

``--against REV`` runs the same child on ``git archive REV hitrobot_server schemas`` for a
side-by-side (the replay before this one held every message: its RSS grows with the file).
Files go to a temporary folder, removed at the end; every run is bounded in time.
"""

from __future__ import annotations

import argparse
import os
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mcap.writer import CompressionType, Writer

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_footprint import code_of  # noqa: E402  (a sibling script: one way to check out a revision)

BLOB = 256 << 10
TIMEOUT = 600.0

CHILD = r"""
import asyncio, resource, sys, time
from hitrobot_server.bus.core import Bus
from hitrobot_server.record.player import Player
from hitrobot_server.record.reading import load_recording
from hitrobot_server.types.registry import TypeRegistry

def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 >> 20

async def main(path, count):
    bus = Bus(TypeRegistry.default())
    base = rss()
    t0 = time.monotonic()
    recording = await asyncio.to_thread(load_recording, path, bus.types)
    opened, after_open = time.monotonic() - t0, rss()
    got = []
    done = asyncio.Event()
    def on(m):
        got.append(1)
        if len(got) == count:
            done.set()
    bus.subscribe("/blob", "acme_msgs/Blob", "k", "/k", on)
    player = Player(bus, recording, speed=100.0, play=True)
    t0 = time.monotonic()
    await player.start()
    await asyncio.wait_for(done.wait(), 600)
    played = time.monotonic() - t0
    await player.stop()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss >> 10
    print(f"RESULT {base} {opened:.3f} {after_open} {peak} {played:.2f} {len(got)}")

asyncio.run(main(sys.argv[1], int(sys.argv[2])))
"""


def write(path: Path, megabytes: int) -> int:
    """A recording of ``megabytes`` MB of /blob messages 1 ms apart; their count."""
    count = max(1, megabytes * 10**6 // BLOB)
    noise = os.urandom(16 << 20)  # each message a different quarter of it: no repeats
    with open(path, "wb") as f:
        writer = Writer(f, chunk_size=1 << 20, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="bench_replay")
        schema = writer.register_schema("acme_msgs/msg/Blob", "ros2msg",
                                        b"uint32 seq\nuint8[] data\n")
        channel = writer.register_channel("/blob", "cdr", schema)
        for i in range(count):
            t = 1_000_000_000 + i * 1_000_000
            at = (i * (BLOB // 4 + 4099)) % (len(noise) - BLOB // 4)
            payload = noise[at: at + BLOB // 4] + bytes(BLOB - BLOB // 4)
            data = b"\x00\x01\x00\x00" + struct.pack("<II", i, BLOB) + payload
            writer.add_message(channel, t, data, t)
        writer.finish()
    return count


def run(path: Path, count: int, code: Path) -> str:
    env = {**os.environ, "PYTHONPATH": str(code)}
    try:
        out = subprocess.run([sys.executable, "-c", CHILD, str(path), str(count)], env=env,
                             capture_output=True, text=True, timeout=TIMEOUT,
                             cwd=path.parent)  # (-c puts the folder it runs in first)
    except subprocess.TimeoutExpired:
        return f"did not finish in {TIMEOUT:.0f} s"
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            base, opened, after, peak, played, got = line.split()[1:]
            return (f"open {float(opened):7.3f} s | RSS base {base:>4} MB, after open "
                    f"{after:>5} MB, peak {peak:>5} MB | played {got} in {played} s")
    return "failed: " + (out.stderr.strip().splitlines() or ["?"])[-1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 1000],
                        metavar="MB", help="MB of messages per recording")
    parser.add_argument("--against", metavar="REV", help="also run the code of this commit")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench_replay_") as tmp:
        folder = Path(tmp)
        codes = {"this tree": ROOT}
        if args.against:
            codes[args.against] = code_of(args.against, folder)
        for megabytes in args.sizes:
            path = folder / f"r{megabytes}.mcap"
            t0 = time.monotonic()
            count = write(path, megabytes)
            print(f"{megabytes} MB of messages ({count} x {BLOB >> 10} KiB), file "
                  f"{path.stat().st_size / 1e6:.0f} MB, written in {time.monotonic() - t0:.1f} s",
                  flush=True)
            for name, code in codes.items():
                print(f"  {name:>10}: {run(path, count, code)}", flush=True)
            path.unlink()


if __name__ == "__main__":
    main()

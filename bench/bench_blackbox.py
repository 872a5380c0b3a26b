"""What the black box (``--black-box``) costs: loop time per message and memory, with the
simulated robot's topics for 60 s (a server in this process, ``--robot sim``, no client), and
what writing it costs (the snapshot's time, its file, the loop's longest stall meanwhile).

Run ``python bench/bench_blackbox.py [SECONDS]``; it prints figures and asserts nothing. The
black box's tap is timed in place (a timing wrapper around it on the bus's tap list); a message
whose CDR nobody had made yet pays its encoding there (then the Zenoh link, Foxglove clients and
a recording share it), so the two kinds are shown apart.
"""

from __future__ import annotations

import asyncio
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from hitrobot_server.bus.topics import Message
from hitrobot_server.config import Settings
from hitrobot_server.procmem import children, rss_bytes
from hitrobot_server.record.blackbox import ITEM_OVERHEAD, BlackBox
from hitrobot_server.record.blackbox_file import Incident, write_black_box
from hitrobot_server.server import HitrobotServer


class TimedTap:
    """The black box's tap, timed: ns per call, by whether the message had its CDR."""

    def __init__(self, box: BlackBox):
        self.box = box
        self.encoded: list[int] = []  # the tap made the CDR
        self.reused: list[int] = []  # the CDR was there

    def message(self, message: Message) -> None:
        had = message.cdr_bytes is not None
        t0 = time.perf_counter_ns()
        self.box.message(message)
        (self.reused if had else self.encoded).append(time.perf_counter_ns() - t0)

    def client_op(self, op) -> None:
        self.box.client_op(op)


def real_size(box: BlackBox) -> int:
    """The buffer's bytes as Python counts them: each tuple, its stamp, seq and CDR object."""
    return sum(sys.getsizeof(item) + sys.getsizeof(item[0]) + sys.getsizeof(item[2])
               + sys.getsizeof(item[3]) for item in box._items)  # noqa: SLF001 - measured


def micro(values: list[int]) -> str:
    if not values:
        return "none"
    values = sorted(values)
    p99 = values[min(len(values) - 1, int(len(values) * 0.99))]
    return (f"{len(values):7d} msgs  mean {statistics.fmean(values) / 1000:6.1f} µs  "
            f"median {values[len(values) // 2] / 1000:6.1f} µs  p99 {p99 / 1000:7.1f} µs")


async def longest_stall(stop: asyncio.Event, period: float = 0.005) -> float:
    worst = 0.0
    while not stop.is_set():
        t0 = time.perf_counter()
        await asyncio.sleep(period)
        worst = max(worst, time.perf_counter() - t0 - period)
    return worst


async def snapshot(control, folder: Path, which: str) -> None:
    """One /record/snapshot (or, ``in a thread``, the same file written by a thread of the
    server): its time, its file, the loop's longest stall meanwhile and, as long again without
    one, the baseline of that stall on this machine."""
    stop = asyncio.Event()
    probe = asyncio.ensure_future(longest_stall(stop))
    t0 = time.perf_counter()
    if which == "in a thread":
        rows = control.box.snapshot()
        name = await asyncio.to_thread(write_black_box, folder, rows,
                                       Incident("snapshot", "bench", time.time()))
        reply = {"path": name, "message": f"{len(rows)} messages"}
    else:
        reply = await control._snapshot({"reason": "bench"})  # noqa: SLF001 - the service
    took = time.perf_counter() - t0
    stop.set()
    stall = await probe
    idle = asyncio.Event()  # the same probe as long, without a snapshot: the baseline
    probe = asyncio.ensure_future(longest_stall(idle))
    await asyncio.sleep(took)
    idle.set()
    baseline = await probe
    path = folder / reply["path"]
    print(f"  snapshot, {which}: {took:.2f} s for {reply['message']}; file "
          f"{path.stat().st_size / 1e6:.1f} MB; longest loop stall meanwhile "
          f"{stall * 1000:.0f} ms (as long without one: {baseline * 1000:.0f} ms)")


async def main(seconds: float) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "recordings"
        server = HitrobotServer(Settings.of(
            port=0, tcp_port=-1, address="127.0.0.1", robot="sim", black_box=seconds,
            state_dir=str(Path(tmp) / "state"), record_dir=str(folder),
            map_dir=str(Path(tmp) / "maps")))
        before = rss_bytes(os.getpid())
        await server.start()
        control = server.black_box
        assert control is not None
        box = control.box
        taps = server.bus.taps
        timed = TimedTap(box)
        taps[taps.index(box)] = timed
        started = time.perf_counter()
        await asyncio.sleep(seconds)
        wall = time.perf_counter() - started
        after = rss_bytes(os.getpid())
        contents = box.contents
        spent = (sum(timed.encoded) + sum(timed.reused)) / 1e9
        count = len(timed.encoded) + len(timed.reused)
        print(f"sim topics for {wall:.0f} s: {count} messages ({count / wall:.0f}/s) on "
              f"{len({item[1].name for item in box._items})} topics")  # noqa: SLF001
        print(f"  tap, CDR made here:     {micro(timed.encoded)}")
        print(f"  tap, CDR already made:  {micro(timed.reused)}")
        print(f"  loop time in the tap:   {spent * 1000:.0f} ms in {wall:.0f} s "
              f"({spent / wall * 100:.2f} % of one core)")
        print(f"  buffer: {contents.messages} messages, {contents.seconds:.1f} s, "
              f"{contents.bytes / 1e6:.1f} MB counted ({ITEM_OVERHEAD} B/message overhead), "
              f"{real_size(box) / 1e6:.1f} MB by sys.getsizeof; process RSS "
              f"{(after - before) / 1e6:+.1f} MB since start (server and sim included)")

        for which in ("in its process", "in its process", "in a thread",
                      "in its process", "in a thread"):
            await snapshot(control, folder, which)
        writers = [rss_bytes(pid) for pid in children(os.getpid())]
        print(f"  writer process RSS: {', '.join(f'{b / 1e6:.0f} MB' for b in writers)}")
        taps[taps.index(timed)] = box
        await server.stop()


if __name__ == "__main__":
    asyncio.run(main(float(sys.argv[1]) if len(sys.argv) > 1 else 60.0))

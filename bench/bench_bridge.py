#!/usr/bin/env python3
"""Loopback benchmark of hitrobot-server: relay rate, LaserScan fan-out, big maps, and a ceiling.

Runs every scenario (or those ``--sections`` names) one after the other, with one summary at
the end; each is also a script of its own. Prints figures only (no assertions, no pass/fail).
Everything runs on 127.0.0.1 with ephemeral ports and temporary state folders; every loop is
bounded in count and in time. Each server under test runs in its own process, so the
measuring clients never share an event loop with it.

    .venv/bin/python bench/bench_bridge.py            # full run, about 2 minutes on 2 cores
    .venv/bin/python bench/bench_bridge.py --quick    # about 20 s
    .venv/bin/python bench/bench_bridge.py --profile-server /tmp/prof   # cProfile each server

Sections:
  1. relay      bench_relay.py: std_msgs/String, 1 publisher -> server -> 1 subscriber, a
                pipelined run with a bounded in-flight window (throughput) and a ping-pong run
                (latency).
  2. fan-out    bench_fanout.py: sensor_msgs/LaserScan (720 ranges) published at max rate to
                1/10/50 clients.
  3. map        bench_map.py: 2000x2000 nav_msgs/OccupancyGrid on a latched topic,
                compression none / png.
  4. ceiling    bench_ceiling.py: section 2 against a bare ``websockets`` server that only
                broadcasts the frames it is sent, and the ratio of our delivered rate (and
                server CPU) to it.
  5. probe      bench_probe_maps.py: a client (its own process) calls /rosapi/get_time every
                5 ms while 2000x2000 and 4000x4000 maps are published to a png and an
                uncompressed subscriber.
  6. memory     bench_memory.py: server RSS with 1000 idle WebSocket clients, and while a
                subscriber stops reading for 30 s (10 s with --quick).

The shared parts are benchlib.py (servers, configuration, tables, command line) and
wsclient.py (the header-parsing WebSocket client the measurements use).
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_ceiling  # noqa: E402  (sibling scripts, not a package)
import bench_fanout  # noqa: E402
import bench_map  # noqa: E402
import bench_memory  # noqa: E402
import bench_probe_maps  # noqa: E402
import bench_relay  # noqa: E402
from benchlib import Config, ceiling_lib_flag, parser, run_main  # noqa: E402


def scenarios(sections: str):
    """The scenarios of ``sections``, in the order they print: 1, 2 and 4 (one interleaved
    run), 3, 5, 6."""

    async def body(cfg: Config) -> list[str]:
        summary = []
        if "1" in sections:
            summary += await bench_relay.scenario(cfg)
        if "4" in sections:
            summary += await bench_ceiling.fanout_and_ceiling(cfg, ours="2" in sections)
        elif "2" in sections:
            summary += await bench_fanout.scenario(cfg)
        if "3" in sections:
            summary += await bench_map.scenario(cfg)
        if "5" in sections:
            summary += await bench_probe_maps.scenario(cfg)
        if "6" in sections:
            summary += await bench_memory.scenario(cfg)
        return summary

    return body


def main() -> int:
    p = parser(__doc__.split("\n\n")[0], fanout=True)
    ceiling_lib_flag(p)
    p.add_argument("--sections", default="123456",
                   help="which sections to run, e.g. 24 (default: all)")
    args = p.parse_args()
    return run_main(args, scenarios(args.sections))


if __name__ == "__main__":
    sys.exit(main())

"""How responsive the bridge stays while the simulated robot works.

Starts ``hitrobot-server`` (simulated robot, mapping on) as a separate process, keeps one
client subscribed to scan/odom/map, sends the robot across the office and measures service
round trips (``/rosapi/get_time``) from another client, compared with an idle robot. Prints
figures; asserts nothing. Loopback only; every loop is bounded in count and time.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import re
import statistics
import subprocess
import sys
import tempfile
import time

from websockets.asyncio.client import connect

NS = "/slamware_ros_sdk_server_node"


async def round_trips(ws, count: int) -> list[float]:
    out = []
    for i in range(count):
        t0 = time.perf_counter()
        await ws.send(json.dumps({"op": "call_service", "id": f"t{i}",
                                  "service": "/rosapi/get_time"}))
        while True:
            msg = json.loads(await asyncio.wait_for(ws.recv(), 5))
            if msg.get("id") == f"t{i}":
                break
        out.append((time.perf_counter() - t0) * 1000)
        await asyncio.sleep(0.01)
    return out


def summary(name: str, rtts: list[float]) -> str:
    rtts = sorted(rtts)
    p99 = rtts[min(len(rtts) - 1, int(len(rtts) * 0.99))]
    return (f"  {name:<34} n={len(rtts):4d}  p50 {statistics.median(rtts):6.2f} ms  "
            f"p99 {p99:6.2f} ms  max {rtts[-1]:6.2f} ms")


async def main(speed: float, count: int) -> None:
    state = tempfile.TemporaryDirectory(prefix="hitrobot-bench-state-")  # never the user's
    proc = subprocess.Popen(
        [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "0",
         "--sim-mapping", "--sim-speed", str(speed), "--log-level", "warning",
         "--state-dir", state.name],
        stdout=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        port = int(re.search(r"ws://[\d.]+:(\d+)", line).group(1))
        url = f"ws://127.0.0.1:{port}"
        async with connect(url, max_size=None) as watcher, connect(url) as probe:
            for topic in ("scan", "odom", "map"):
                await watcher.send(json.dumps({"op": "subscribe", "topic": f"{NS}/{topic}"}))

            async def drain() -> None:
                async for _ in watcher:
                    pass

            reader = asyncio.create_task(drain())
            await asyncio.sleep(1.0)
            idle = await round_trips(probe, count)
            await probe.send(json.dumps({"op": "publish", "topic": f"{NS}/move_to", "msg": {
                "location": {"x": 20.0, "y": 8.2, "z": 0.0},
                "options": {"opt_flags": {"flags": 0},
                            "speed_ratio": {"is_valid": False, "value": 0.0}},
                "yaw": 0.0}}))
            await asyncio.sleep(0.5)
            moving = await round_trips(probe, count)
            reader.cancel()
        print("hitrobot-server responsiveness (server in its own process, loopback)")
        print(f"  simulated robot mapping, sim speed x{speed}; a client receives scan, odom, map")
        print(summary("get_time round trip, robot idle", idle))
        print(summary("get_time round trip, robot driving", moving))
    finally:
        proc.terminate()
        proc.wait(10)
        state.cleanup()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--speed", type=float, default=1.0, help="simulator time scale")
    parser.add_argument("--count", type=int, default=300, help="round trips per phase")
    args = parser.parse_args()
    asyncio.run(main(args.speed, args.count))

"""What a VDA 5050 link costs: the state latency and the event loop's time per robot.

1. **State latency**: a node reached on the bus (the robot's ``intelligent_navigate_to_pose``
   goal SUCCEEDED on its status topic) → the ``state`` naming that node as ``lastNodeId``
   received by a master (a plain aiomqtt client) through mosquitto. Short hops of one simulated
   robot; median, 90th percentile and worst, in milliseconds.
2. **Cost per robot**: the server's CPU time per second (process time: the event loop and the
   simulator's threads) with N simulated robots, without ``--vda5050``, with it and the links
   idle, and with every robot driving VDA 5050 orders back and forth (against the same hops
   driven by bus goals without VDA 5050); the difference divided by N is the link's cost per
   robot. The loop's lateness (a 10 ms timer's worst delay) is printed beside it.

Debian's mosquitto on a free loopback port, temporary state folders; prints figures, asserts
nothing. ``python bench/bench_vda5050.py [--robots 1,4] [--seconds 8] [--hops 20]``.
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hitrobot_server.bus.namespace import Namespace  # noqa: E402
from hitrobot_server.config import Settings  # noqa: E402
from hitrobot_server.robot.options import RobotEntry  # noqa: E402
from hitrobot_server.server import HitrobotServer  # noqa: E402
from hitrobot_server.vda5050.driver import NAVIGATE, navigation_goal  # noqa: E402
from tests.vda5050.conftest import Broker  # noqa: E402
from tests.vda5050.master import Master, node  # noqa: E402

Y = 8.0
HOP = 0.6  # metres between two nodes


async def start(folder: Path, broker: Broker | None, robots: int) -> HitrobotServer:
    kw: dict = {"port": 0, "tcp_port": -1, "address": "127.0.0.1",
                "state_dir": str(Path(tempfile.mkdtemp(dir=folder))),
                "map_dir": str(Path(tempfile.mkdtemp(dir=folder)))}
    if robots == 1:
        kw["robot"] = "sim"
    else:
        kw["robots"] = tuple(RobotEntry(f"r{i}", "sim", (3.0 + 1.5 * i, Y, 0.0))
                             for i in range(robots))
    if broker is not None:
        kw["vda5050"] = broker.url
    server = HitrobotServer(Settings.of(**kw))
    await server.start()
    return server


async def latency(folder: Path, hops: int) -> list[float]:
    broker = Broker(folder)
    server = await start(folder, broker, 1)
    reached: dict[str, float] = {}
    seen: dict[str, float] = {}
    try:
        def on_status(message) -> None:
            for goal in message.msg["status_list"]:
                key = bytes(goal["goal_info"]["goal_id"]["uuid"]).hex()
                if goal["status"] == 4 and key not in reached:
                    reached[key] = time.perf_counter()

        server.bus.subscribe(f"{NAVIGATE}/_action/status", None, "bench", "/bench", on_status)
        async with Master(broker.port) as master:
            here = (await master.sync())["agvPosition"]
            x0 = here["x"]
            for i in range(hops):
                a, b = (x0, x0 + HOP) if i % 2 == 0 else (x0 + HOP, x0)
                before = set(reached)
                await master.order(f"hop{i}", 0, [node("a", 0, a, Y), node(f"b{i}", 2, b, Y)])
                state = await master.state(lambda s, i=i: s["lastNodeId"] == f"b{i}",
                                           f"hop {i}", 30)
                seen[f"b{i}"] = time.perf_counter()
                new = [reached[k] for k in reached if k not in before]
                if new and state:
                    seen[f"b{i}"] -= max(new)
                else:
                    seen.pop(f"b{i}")
    finally:
        await server.stop()
        broker.stop()
    return [v * 1000 for v in seen.values()]


async def loop_probe(seconds: float) -> tuple[float, float]:
    """(CPU seconds per second, worst lateness of a 10 ms timer in ms) over ``seconds``."""
    loop = asyncio.get_running_loop()
    cpu0, end, worst = time.process_time(), loop.time() + seconds, 0.0
    t0 = time.perf_counter()
    while loop.time() < end:
        before = time.perf_counter()
        await asyncio.sleep(0.01)
        worst = max(worst, time.perf_counter() - before - 0.01)
    return (time.process_time() - cpu0) / (time.perf_counter() - t0), worst * 1000


async def drive_by_goals(server: HitrobotServer, robots: int, stop: asyncio.Event) -> None:
    async def one(i: int) -> None:
        name = f"r{i}" if robots > 1 else ""
        action = Namespace(name).resolve(NAVIGATE) if name else NAVIGATE
        x0 = 3.0 + 1.5 * i if robots > 1 else 5.0
        leg = 0
        while not stop.is_set():
            x = x0 + (HOP if leg % 2 == 0 else 0.0)
            _handle, outcome = server.bus.start_goal(action, navigation_goal(x, Y, None, "/map"))
            await outcome
            leg += 1

    await asyncio.gather(*(one(i) for i in range(robots)))


async def drive_by_orders(broker: Broker, server: HitrobotServer, robots: int,
                          stop: asyncio.Event) -> None:
    async def one(i: int) -> None:
        serial = f"r{i}" if robots > 1 else "robot"
        async with Master(broker.port, serial=serial) as master:
            x0 = (await master.sync())["agvPosition"]["x"]
            leg = 0
            while not stop.is_set():
                a, b = (x0, x0 + HOP) if leg % 2 == 0 else (x0 + HOP, x0)
                await master.order(f"{serial}-{leg}", 0,
                                   [node("a", 0, a, Y), node(f"b{leg}", 2, b, Y)])
                await master.state(lambda s, leg=leg: s["lastNodeId"] == f"b{leg}",
                                   f"leg {leg}", 60)
                leg += 1

    await asyncio.gather(*(one(i) for i in range(robots)))


async def cost(folder: Path, robots: int, seconds: float) -> dict[str, tuple[float, float]]:
    out = {}
    for mode in ("off idle", "on idle", "off driving", "on driving"):
        broker = Broker(folder) if mode.startswith("on") else None
        server = await start(folder, broker, robots)
        stop = asyncio.Event()
        driver = None
        try:
            await asyncio.sleep(2.0)  # settled: robots connected, links up
            if mode == "off driving":
                driver = asyncio.ensure_future(drive_by_goals(server, robots, stop))
            elif mode == "on driving":
                driver = asyncio.ensure_future(drive_by_orders(broker, server, robots, stop))
            if driver is not None:
                await asyncio.sleep(1.0)
            out[mode] = await loop_probe(seconds)
        finally:
            stop.set()
            if driver is not None:
                driver.cancel()
                await asyncio.gather(driver, return_exceptions=True)
            await server.stop()
            if broker is not None:
                broker.stop()
    return out


async def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", default="1,4")
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--hops", type=int, default=20)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-vda5050-") as tmp:
        folder = Path(tmp)
        ms = await latency(folder, args.hops)
        ms.sort()
        print(f"state latency (node reached on the bus -> state at a master), {len(ms)} nodes: "
              f"median {statistics.median(ms):.0f} ms, p90 {ms[int(0.9 * (len(ms) - 1))]:.0f} "
              f"ms, worst {ms[-1]:.0f} ms")
        for n in (int(v) for v in args.robots.split(",")):
            figures = await cost(folder, n, args.seconds)
            line = ", ".join(f"{mode}: {cpu * 1000:.0f} ms CPU/s (loop late <= {late:.0f} ms)"
                             for mode, (cpu, late) in figures.items())
            idle = (figures["on idle"][0] - figures["off idle"][0]) / n * 1000
            busy = (figures["on driving"][0] - figures["off driving"][0]) / n * 1000
            print(f"{n} robot(s): {line}")
            print(f"  a link costs {idle:.1f} ms CPU/s per robot idle, {busy:.1f} ms CPU/s per "
                  f"robot driving")


if __name__ == "__main__":
    asyncio.run(main())

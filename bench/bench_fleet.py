"""Several simulated robots in one world: the step cost per robot as the fleet grows, how long
``/fleet/dispatch`` takes to take every robot's bid and answer, and the queue's defences (issue
37): 10,000 dispatches against the bounded queue, 300 to a place no robot can reach (refused;
the server's CPU afterwards).

Run ``python bench/bench_fleet.py``; it prints figures and asserts nothing. Every robot drives
a goal across the office corridor while stepping, so the others move through its lidar and
costmap.
"""

from __future__ import annotations

import asyncio
import tempfile
import time

from hitrobot_server.config import Settings
from hitrobot_server.robot.factory import shared_world
from hitrobot_server.robot.model import Point2D, Pose2D
from hitrobot_server.robot.options import RobotEntry, RobotOptions
from hitrobot_server.server import HitrobotServer

STEP = 0.05
CORRIDOR_Y = 8.0


def step_cost(robots: int, seconds: float = 20.0) -> tuple[float, float]:
    """Mean and worst wall time (ms) of one 0.05 s step of every robot together."""
    world = shared_world(RobotOptions())
    sims = [world.add(i, Pose2D(2.0 + 2.5 * i, CORRIDOR_Y, 0.0), 1.0).simulator
            for i in range(robots)]
    for i, sim in enumerate(sims):  # half drive east, half west: they meet and pass
        sim.actions.move_to([Point2D(20.0 if i % 2 == 0 else 1.5, CORRIDOR_Y)])
    worst, started = 0.0, time.perf_counter()
    count = round(seconds / STEP)
    for _ in range(count):
        t0 = time.perf_counter()
        for sim in sims:
            sim.step(STEP)
        worst = max(worst, time.perf_counter() - t0)
    return (time.perf_counter() - started) / count * 1000.0, worst * 1000.0


async def dispatch_time(robots: int, rounds: int = 5) -> float:
    """Median ms from a /fleet/dispatch call (nearest idle robot, plans for each) to its
    answer, cancelled at once so every round sees all robots idle."""
    entries = tuple(RobotEntry(f"r{i}", "sim", (2.0 + 2.5 * i, CORRIDOR_Y, 0.0))
                    for i in range(robots))
    with tempfile.TemporaryDirectory() as maps:
        server = HitrobotServer(Settings.of(port=0, tcp_port=0, robots=entries, map_dir=maps))
        await server.start()
        try:
            fleet = server.nodes[-1]
            deadline = time.monotonic() + 20
            while len(fleet.free()) < robots and time.monotonic() < deadline:
                await asyncio.sleep(0.1)
            times = []
            target = {"position": {"x": 20.0, "y": CORRIDOR_Y, "z": 0.0},
                      "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
            for _ in range(rounds):
                t0 = time.perf_counter()
                reply = await server.bus.call_service(
                    "/fleet/dispatch", {"poi": "", "pose": target, "robot": ""})
                times.append(time.perf_counter() - t0)
                await server.bus.call_service("/fleet/cancel", {"task": reply["task"]})
                deadline = time.monotonic() + 10
                while len(fleet.free()) < robots and time.monotonic() < deadline:
                    await asyncio.sleep(0.1)
            return sorted(times)[len(times) // 2] * 1000.0
        finally:
            await server.stop()


def _pose(x: float, y: float) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}


async def defences(flood: int = 10_000, unreachable: int = 300) -> None:
    """The bounded queue and the unreachable places, on two robots (b out of service, so the
    flood's tasks named for it stay queued)."""
    entries = (RobotEntry("a", "sim", (4.0, CORRIDOR_Y, 0.0)),
               RobotEntry("b", "sim", (12.0, CORRIDOR_Y, 0.0)))
    with tempfile.TemporaryDirectory() as maps, tempfile.TemporaryDirectory() as state:
        server = HitrobotServer(Settings.of(port=0, tcp_port=0, robots=entries, map_dir=maps,
                                            state_dir=state))
        await server.start()
        try:
            fleet = next(n for n in server.nodes if n.name == "/fleet")
            deadline = time.monotonic() + 20
            while len(fleet.free()) < 2 and time.monotonic() < deadline:
                await asyncio.sleep(0.1)
            call = server.bus.call_service
            await call("/fleet/set_in_service", {"robot": "b", "in_service": False})
            t0 = time.perf_counter()
            replies = [await call("/fleet/dispatch", {"poi": "", "pose": _pose(10.0, CORRIDOR_Y),
                                                      "robot": "b"}) for _ in range(flood)]
            took = time.perf_counter() - t0
            kept = sum(r["accepted"] for r in replies)
            print(f"{flood} dispatches for one robot: {kept} queued, {flood - kept} refused "
                  f"('{replies[-1]['message']}'), {took:.1f} s in all")
            t0 = time.perf_counter()
            replies = await asyncio.gather(*(call("/fleet/dispatch", {
                "poi": "", "pose": _pose(10.0, 0.1), "robot": ""}, timeout=600)
                for _ in range(unreachable)))
            took = time.perf_counter() - t0
            refused = sum(not r["accepted"] for r in replies)
            cpu0, wall0 = time.process_time(), time.perf_counter()
            await asyncio.sleep(3.0)
            share = (time.process_time() - cpu0) / (time.perf_counter() - wall0)
            print(f"{unreachable} dispatches to an unreachable place: {refused} refused in "
                  f"{took:.1f} s; the process afterwards: {share:.0%} of a core (two robots "
                  "simulated)")
        finally:
            await server.stop()


def main() -> None:
    for robots in (1, 2, 4, 6):
        mean, worst = step_cost(robots)
        print(f"{robots} robot(s) in one world: step of all {mean:.2f} ms mean, {worst:.1f} ms "
              f"worst ({mean / robots:.2f} ms per robot)")
    for robots in (2, 4):
        ms = asyncio.run(dispatch_time(robots))
        print(f"/fleet/dispatch with {robots} idle robots: {ms:.0f} ms median to the answer")
    asyncio.run(defences())


if __name__ == "__main__":
    main()

"""Throughput of the simulator: ``Simulator.step`` rate and the cost of one lidar scan.

Run ``python bench/bench_sim.py``; it prints figures and asserts nothing. Steps are 0.05 s of
simulated time (the backend's default 20 Hz), i.e. two 40 Hz physics ticks each. The last lines
are REST round trips from the Slamware client to a sim-device on loopback.
"""

from __future__ import annotations

import asyncio
import time

import numpy as np

from hitrobot_server.robot.model import Point2D, Pose2D, Rect
from hitrobot_server.robot.planning.planner import plan
from hitrobot_server.robot.sim.lidar import Lidar, LidarConfig, RayCaster
from hitrobot_server.robot.sim.simulator import SimConfig, Simulator
from hitrobot_server.robot.sim.world import load_world

STEP = 0.05


def steps_per_second(sim: Simulator, seconds: float) -> tuple[float, float]:
    """Mean steps per wall second and the slowest step (ms) over ``seconds`` of sim time."""
    count = round(seconds / STEP)
    worst = 0.0
    started = time.perf_counter()
    for _ in range(count):
        t0 = time.perf_counter()
        sim.step(STEP)
        worst = max(worst, time.perf_counter() - t0)
    return count / (time.perf_counter() - started), worst * 1000.0


def main() -> None:
    world = load_world()
    print(f"world {world.name}: {world.spec.width}x{world.spec.height} cells")

    idle = Simulator(world, seed=0)
    rate, worst = steps_per_second(idle, 20.0)
    print(f"step, idle:                  {rate:8.0f} steps/s   worst {worst:6.1f} ms")

    moving = Simulator(world, seed=0)
    moving.actions.move_to([Point2D(21.0, 10.3)])
    rate, worst = steps_per_second(moving, 30.0)
    print(f"step, navigating:            {rate:8.0f} steps/s   worst {worst:6.1f} ms")

    mapping = Simulator(world, seed=0, config=SimConfig(prebuilt_map=False, map_update=True))
    mapping.actions.move_to([Point2D(21.0, 10.3)])
    rate, worst = steps_per_second(mapping, 30.0)
    print(f"step, navigating + mapping:  {rate:8.0f} steps/s   worst {worst:6.1f} ms")

    lidar = Lidar(RayCaster(world.spec, world.solid), LidarConfig(), np.random.default_rng(0))
    poses = [Pose2D(5.0 + 0.05 * i, 8.0, 0.01 * i) for i in range(200)]
    started = time.perf_counter()
    for pose in poses:
        lidar.measure(pose)
    per_scan = (time.perf_counter() - started) / len(poses) * 1000.0
    print(f"lidar, 360 beams, 12 m:      {per_scan:8.2f} ms/scan")

    costmap = idle.costmap()
    started = time.perf_counter()
    result = plan(costmap, (5.0, 8.0), (21.0, 10.3))
    spent = (time.perf_counter() - started) * 1000
    print(f"A* corridor -> meeting room: {spent:8.1f} ms (found: {result.ok})")

    reloc = Simulator(world, seed=0)
    reloc.set_pose(Pose2D(15.0, 3.3, 2.5))
    search = reloc.start_relocalization(None)
    started = time.perf_counter()
    while not search.advance(1 << 30):
        pass
    print(f"global relocalization:       {(time.perf_counter() - started) * 1000:8.1f} ms")

    asyncio.run(rest_round_trips())


async def rest_round_trips(count: int = 200) -> None:
    """Mean wall time of the node's most frequent REST calls against a sim-device."""
    from hitrobot_server.robot.device import SimDevice
    from hitrobot_server.robot.rest.client import SlamwareRestBackend

    device = SimDevice(Simulator(load_world(), seed=0), port=0)
    await device.start()
    client = SlamwareRestBackend(device.url)
    await client.link.start()
    while not client.link.connected:
        await asyncio.sleep(0.01)
    calls = {
        "odometry (pose + speed)": client.sensors.get_odometry,
        "laser scan, 360 points": client.sensors.get_laser_scan,
        "explore map, 16 m window": lambda: client.maps.get_map(Rect(2.0, 0.0, 16.0, 16.0)),
    }
    try:
        for name, call in calls.items():
            started = time.perf_counter()
            for _ in range(count):
                await call()
            per_call = (time.perf_counter() - started) / count * 1000.0
            print(f"REST {name + ':':27s}{per_call:6.2f} ms/call")
    finally:
        await client.link.stop()
        await device.stop()


if __name__ == "__main__":
    main()

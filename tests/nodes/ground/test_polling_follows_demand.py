"""Nothing polled that nobody reads (issue 50): a robot's topics are fetched at their rates only
while something reads them (a client, the recorder, the black box at its own rate), at a slow
keep-alive otherwise; health, battery and the fleet's view keep updating all along.

Each window is measured by the server's own slow topics (a number of their messages), never a
sleep: ``/fleet/robots`` (2 Hz) for the REST robot, the basic state (1 Hz) for the simulator.
"""

from __future__ import annotations

import time
from collections import Counter

from hitrobot_server.bus.topics import Message
from hitrobot_server.robot.device import SimDevice
from hitrobot_server.robot.factory import build_simulator
from hitrobot_server.robot.options import RobotEntry
from hitrobot_server.robot.rest import paths
from tests.helpers import Watcher

NS = "/slamware_ros_sdk_server_node"
FLEET = "/fleet/robots"
DIAGNOSTICS = "/a/diagnostics_agg"


async def requests_per_second(device: SimDevice, w: Watcher, clock: str,
                              ticks: int) -> dict[str, float]:
    """The device's requests per second by path while ``ticks`` messages of ``clock`` come."""
    before, began = Counter(device.hits), time.monotonic()
    for _ in range(ticks):
        await w.next(clock, timeout=10)
    seconds = time.monotonic() - began
    return {path: (device.hits[path] - before[path]) / seconds
            for path in (paths.LASERSCAN, paths.SPEED)}


def robot_a(w: Watcher) -> dict:
    latest = w.latest(FLEET)
    return next((r for r in latest["robots"] if r["name"] == "a"), {}) if latest else {}


async def test_a_rest_topic_nobody_reads_is_polled_slowly_and_a_reader_brings_its_rate_back(
        make_server, tmp_path):
    device = SimDevice(build_simulator(), port=0)
    await device.start()
    server = await make_server(robots=(RobotEntry("a", device.url),), map_dir=str(tmp_path))
    w = await Watcher.open(server.port)
    try:
        state = f"/a{NS}/robot_basic_state"
        for topic in (FLEET, state, DIAGNOSTICS):
            await w.subscribe(topic)
        await w.until(lambda: robot_a(w).get("state") == "idle", 15, "robot a idle")
        await w.next(state)

        fleet, diagnostics, states = (len(w.messages[t]) for t in (FLEET, DIAGNOSTICS, state))
        idle = await requests_per_second(device, w, FLEET, 6)
        assert idle[paths.LASERSCAN] < 3, idle  # 10 Hz when read; the keep-alive every 2 s
        assert idle[paths.SPEED] < 5, idle  # 20 Hz twice (pose, locomotion) when read
        # meanwhile health, battery and the fleet's view went on
        assert len(w.messages[FLEET]) >= fleet + 6 and len(w.messages[state]) > states
        assert robot_a(w)["battery"] > 0 and robot_a(w)["state"] == "idle"
        assert w.latest(state)["battery_percentage"] > 0
        assert len(w.messages[DIAGNOSTICS]) > diagnostics
        items = {s["name"]: s for s in w.latest(DIAGNOSTICS)["status"]}
        assert {"Battery", "Health"} <= {n.rsplit("/", 1)[-1] for n in items}, sorted(items)

        await w.subscribe(f"/a{NS}/scan")
        await w.subscribe(f"/a{NS}/odom")
        await w.next(f"/a{NS}/scan")
        read = await requests_per_second(device, w, FLEET, 6)
        assert read[paths.LASERSCAN] > 5, read
        assert read[paths.SPEED] > 10, read

        for topic in (f"/a{NS}/scan", f"/a{NS}/odom"):
            await w.client.send({"op": "unsubscribe", "id": f"w:{topic}", "topic": topic})
        await w.next(FLEET)
        again = await requests_per_second(device, w, FLEET, 6)
        assert again[paths.LASERSCAN] < 3 and again[paths.SPEED] < 5, again
    finally:
        await w.close()
        await server.stop()
        await device.stop()


class Count:
    """A bus tap counting the publishes of one topic (it asks for nothing to be polled)."""

    def __init__(self, topic: str) -> None:
        self.topic, self.seen = topic, 0

    def message(self, message: Message) -> None:
        self.seen += message.topic.name == self.topic

    def client_op(self, op) -> None:
        pass


async def publishes_per_second(server, w: Watcher, topic: str, ticks: int = 3) -> float:
    count = Count(topic)
    server.bus.taps.append(count)
    began = time.monotonic()
    try:
        for _ in range(ticks):
            await w.next(f"{NS}/robot_basic_state", timeout=10)
    finally:
        server.bus.taps.remove(count)
    return count.seen / (time.monotonic() - began)


async def test_the_simulator_publishes_unread_scans_slowly_and_the_black_box_at_its_rate(
        make_server):
    server = await make_server(robot="sim")
    w = await Watcher.open(server.port)
    try:
        await w.subscribe(f"{NS}/robot_basic_state")
        await w.next(f"{NS}/robot_basic_state")
        assert await publishes_per_second(server, w, f"{NS}/scan") < 2.5  # a keep-alive every 2 s
        await w.subscribe(f"{NS}/scan")
        await w.next(f"{NS}/scan")
        assert await publishes_per_second(server, w, f"{NS}/scan") > 6  # 10 Hz
    finally:
        await w.close()
    boxed = await make_server(robot="sim", black_box=30.0)
    w = await Watcher.open(boxed.port)
    try:
        await w.subscribe(f"{NS}/robot_basic_state")
        await w.next(f"{NS}/robot_basic_state")
        rate = await publishes_per_second(boxed, w, f"{NS}/scan")
        assert 3 < rate < 7, rate  # the black box alone: 5 Hz
    finally:
        await w.close()

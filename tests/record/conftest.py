"""A recording of the simulator driving, made once for the record and replay tests."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest
import roslibpy

from tests.helpers import ServerProcess, connect_roslibpy

ODOM = "/odom"
SCAN = "/scan"
TWIST = {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.4}}


def record_server(folder: Path, path: Path, *extra: str) -> ServerProcess:
    return ServerProcess("--record", str(path), "--map-dir", str(folder / "maps"),
                         "--record-dir", str(folder), "--sim-seed", "1", *extra, robot="sim")


def rate(times: list[float]) -> float:
    return (len(times) - 1) / (times[-1] - times[0])


@pytest.fixture(scope="package")
def drive(tmp_path_factory):
    """8 s of the simulated robot driving under /cmd_vel (10 Hz, paced by odom at 20 Hz),
    recorded by the server; the live arrival times of odom and scan, for the rates."""
    folder = tmp_path_factory.mktemp("drive")
    path = folder / "drive.mcap"
    server = record_server(folder, path)
    live: dict[str, list[float]] = {ODOM: [], SCAN: []}
    done = threading.Event()
    try:
        ros = connect_roslibpy(server.port)
        cmd = roslibpy.Topic(ros, "/cmd_vel", "geometry_msgs/Twist")
        cmd.advertise()

        def on_odom(_msg):
            live[ODOM].append(time.monotonic())
            if len(live[ODOM]) % 2 == 0 and not done.is_set():
                cmd.publish(roslibpy.Message(TWIST))
            if len(live[ODOM]) >= 161:
                done.set()

        odom = roslibpy.Topic(ros, ODOM, "nav_msgs/Odometry")
        odom.subscribe(on_odom)
        scan = roslibpy.Topic(ros, SCAN, "sensor_msgs/LaserScan")
        scan.subscribe(lambda _m: live[SCAN].append(time.monotonic()))
        # a robot service (audited) and a rosapi one (read-only: not audited)
        roslibpy.Service(ros, "/planning/clear_waypoints", "std_srvs/Trigger").call(
            roslibpy.ServiceRequest({}), timeout=10)
        roslibpy.Service(ros, "/rosapi/get_time", "rosapi/GetTime").call(
            roslibpy.ServiceRequest({}), timeout=10)
        assert done.wait(30), f"only {len(live[ODOM])} odom messages"
        odom.unsubscribe()
        scan.unsubscribe()
        ros.close()
    finally:
        server.stop()  # SIGTERM: the recording is finished with its summary
    assert server.proc.returncode == 0, "".join(server.output)
    return path, live



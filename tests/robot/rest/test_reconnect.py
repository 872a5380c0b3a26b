"""A robot that drops off the network: the server keeps its clients, refuses motion with a
``status`` error, and resumes publishing when the robot is back, without a restart."""

from __future__ import annotations

import asyncio
import logging
import time

from hitrobot_server.nodes.options import SlamwareParams
from hitrobot_server.robot.device import SimDevice
from hitrobot_server.robot.factory import build_simulator
from tests.helpers import Watcher

NS = "/slamware_ros_sdk_server_node"
RECONN_WAIT = 0.5
POSE_PERIOD = 0.05


def move_to(x: float, y: float) -> dict:
    return {"location": {"x": x, "y": y, "z": 0.0},
            "options": {"opt_flags": {"flags": 0},
                        "speed_ratio": {"is_valid": False, "value": 0.0}},
            "yaw": 0.0}


async def test_the_robot_going_away_and_coming_back(make_server, caplog):
    caplog.set_level(logging.INFO)
    escaped: list[dict] = []
    asyncio.get_running_loop().set_exception_handler(lambda _loop, ctx: escaped.append(ctx))
    device = SimDevice(build_simulator(), port=0, time_scale=4.0)
    await device.start()
    server = await make_server(robot=device.url, slamware=SlamwareParams(
        reconn_wait_ms=round(RECONN_WAIT * 1000)))
    w = await Watcher.open(server.port)
    try:
        odom, device_info = f"{NS}/odom", f"{NS}/robot_device_info"
        await w.subscribe(odom, "nav_msgs/Odometry")
        await w.subscribe(device_info)
        await w.until(lambda: w.latest(odom), 10, "odometry")
        await w.until(lambda: w.latest(device_info), 5, "device info")

        port = device.port
        await device.stop()  # the robot drops off the network mid-run
        await w.until(lambda: not server.robot.link.connected, 5, "the loss to be noticed")
        await asyncio.sleep(0.2)
        count = len(w.messages[odom])
        await asyncio.sleep(RECONN_WAIT * 2)
        assert len(w.messages[odom]) == count  # nothing to publish while the robot is away

        # clients stay connected and get told why their requests fail
        await w.publish(f"{NS}/move_to", move_to(6.0, 8.0), op_id="away")
        status = await w.until(
            lambda: next((s for s in w.statuses if s.get("id") == "away"), None), 5, "status")
        assert status["level"] == "error" and "not connected" in status["msg"]
        stcm = await w.call(f"{NS}/sync_get_stcm")
        assert stcm["result"] is False and "not connected" in stcm["values"]
        assert (await w.call("/rosapi/get_time"))["result"] is True

        infos = len(w.messages[device_info])
        back = time.monotonic()
        await device.start()  # same port, the robot is back
        assert device.port == port
        await w.until(lambda: len(w.messages[odom]) > count, 10, "odometry to resume")
        resumed = w.messages[odom][count][0] - back
        print(f"resumed after {resumed:.3f} s")
        assert resumed <= RECONN_WAIT + POSE_PERIOD + 0.25, f"resumed after {resumed:.2f} s"
        await w.until(lambda: len(w.messages[device_info]) > infos, 5, "device info again")

        # requests work again
        await w.publish(f"{NS}/move_to", move_to(6.0, 8.0), op_id="back")
        await asyncio.sleep(0.5)
        assert not [s for s in w.statuses if s.get("id") == "back" and s["level"] == "error"]
        assert server.robot.link.connected

        # the whole outage was logged as warnings, nothing escaped (checked before teardown,
        # which is not what this test is about)
        messages = [r.getMessage() for r in caplog.records]
        assert any("lost the Slamware robot" in m for m in messages)
        assert any("connected to the Slamware robot" in m for m in messages)
        assert not [r for r in caplog.records if r.exc_info or "Traceback" in r.getMessage()]
        assert not [r for r in caplog.records if r.levelno >= logging.ERROR], \
            [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]
        assert escaped == []
    finally:
        await w.close()
        await server.stop()
        await device.stop()

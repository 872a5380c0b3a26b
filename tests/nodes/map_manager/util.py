"""Shared helpers of the map manager and navigation tests (real server, real clients)."""

from __future__ import annotations

import math

from tests.helpers import Watcher

NS = "/slamware_ros_sdk_server_node"
MM = "/map_manager"
SPEED = 4.0  # simulated seconds per wall second
FREE, OBSTACLE, BLOCKED, NOT_MASKED = 0, 99, 100, -1
SLAM_LAYER, MASKING_LAYER, KINECT_LAYER, SICK_LAYER = 0, 1, 2, 3


async def start(make_server, map_dir, **kw):
    """(server, watcher): a simulated robot, statuses at level info, odom and /map watched."""
    server = await make_server(robot="sim", sim_speed=SPEED, map_dir=str(map_dir), **kw)
    w = await Watcher.open(server.port)
    await w.client.send({"op": "set_level", "level": "info"})
    await w.subscribe(f"{NS}/odom", "nav_msgs/Odometry")
    await w.subscribe("/map", "nav_msgs/OccupancyGrid")
    await w.subscribe(f"{MM}/pois", "map_messages/PointsOfInterest")
    await w.until(lambda: w.latest(f"{NS}/odom"), 10, "odometry")
    await w.until(lambda: w.latest("/map"), 10, "the composed map")
    return server, w


def pose(x: float, y: float, yaw: float = 0.0) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}


def poi(name: str, x: float, y: float, yaw: float = 0.0, kind: int = 100,
        remarks: str = "") -> dict:
    return {"type": kind, "name": name, "remarks": remarks, "pose": pose(x, y, yaw)}


def rect(x0: float, y0: float, x1: float, y1: float) -> list[dict]:
    return [{"x": x, "y": y, "z": 0.0} for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]


async def status_for(w: Watcher, op_id: str, timeout: float = 10.0,
                     levels: tuple[str, ...] = ("info", "warning", "error")) -> dict:
    """The first status a node sent about the publish op ``op_id``."""
    return await w.until(
        lambda: next((s for s in w.statuses if s.get("id") == op_id and s["level"] in levels
                      and s["msg"].startswith("publish to ")), None), timeout,
        f"a status for {op_id}")


async def request(w: Watcher, topic: str, type_name: str, msg: dict, op_id: str,
                  timeout: float = 10.0) -> dict:
    """Publish a request and wait for its status (info on success, error when refused)."""
    await w.client.send({"op": "advertise", "topic": topic, "type": type_name})
    await w.publish(topic, msg, op_id=op_id)
    return await status_for(w, op_id, timeout)


async def modify_map(w: Watcher, op_id: str, region: list[dict], action: int,
                     layer: int = MASKING_LAYER) -> dict:
    return await request(w, f"{MM}/modify_map", "map_messages/ModifyMap",
                         {"region": region, "maskAction": action, "mapLayer": layer}, op_id)


def current(w: Watcher) -> tuple[float, float, float]:
    from hitrobot_server.nodes.ground.messages import yaw_of

    p = w.latest(f"{NS}/odom")["pose"]["pose"]
    return p["position"]["x"], p["position"]["y"], yaw_of(p["orientation"])


def still(w: Watcher) -> bool:
    twist = w.latest(f"{NS}/odom")["twist"]["twist"]
    return abs(twist["linear"]["x"]) < 1e-3 and abs(twist["angular"]["z"]) < 1e-3


def cell(grid: dict, x: float, y: float) -> int:
    info = grid["info"]
    col = math.floor((x - info["origin"]["position"]["x"]) / info["resolution"])
    row = math.floor((y - info["origin"]["position"]["y"]) / info["resolution"])
    return grid["data"][row * info["width"] + col]

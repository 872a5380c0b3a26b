"""``RestSensors``: what the robot senses and reports about itself, over the Slamware REST API.

Basic sensors (bumpers, cliffs, sonars) are not in the REST API: none.
"""

from __future__ import annotations

import asyncio
import time

from ... import __version__
from ..backend import SensorBackend
from ..model import BasicSensorInfo, BasicSensorValue, DeviceInfo, HealthInfo, LaserScan, Odometry
from . import paths, shapes
from .link import RestLink


class RestSensors(SensorBackend):
    """Odometry, the lidar, identity and health."""

    def __init__(self, link: RestLink) -> None:
        self._link = link

    async def get_odometry(self) -> Odometry:
        stamp = time.time()
        pose, twist = await asyncio.gather(self._link.get(paths.POSE, shapes.pose_from),
                                           self._link.get(paths.SPEED, shapes.speed_from))
        return Odometry(pose, twist, stamp)

    async def get_laser_scan(self) -> LaserScan:
        stamp = time.time()  # like the ROS node: the time the request started
        return await self._link.get(paths.LASERSCAN, lambda v: shapes.laser_scan_from(v, stamp))

    async def get_sensors_info(self) -> list[BasicSensorInfo]:
        """Not in the REST API: no basic sensors."""
        self._link.require_connection()
        return []

    async def get_sensor_values(self) -> dict[int, BasicSensorValue]:
        self._link.require_connection()
        return {}

    async def get_device_info(self) -> DeviceInfo:
        sdk = f"hitrobot-server {__version__} (REST)"
        return await self._link.get(paths.ROBOT_INFO, lambda v: shapes.device_info_from(v, sdk))

    async def get_health(self) -> HealthInfo:
        return await self._link.get(paths.ROBOT_HEALTH, shapes.health_from)

    async def clear_health_error(self, error_code: int) -> bool:
        # 400 "Invalid Error Code" or 404: not active
        return await self._link.removal("DELETE", f"{paths.ROBOT_HEALTH}/{int(error_code)}",
                                        absent=(400, 404))

"""The simulated robot's odometry, lidar, bumpers, identity and health."""

from __future__ import annotations

from ...backend import SensorBackend
from ...model import (
    BasicSensorInfo,
    BasicSensorValue,
    DeviceInfo,
    HealthInfo,
    LaserScan,
    Odometry,
)
from .part import SimPart


class SimSensors(SimPart, SensorBackend):
    async def get_odometry(self) -> Odometry:
        return self._call(self.simulator.odometry)

    async def get_laser_scan(self) -> LaserScan:
        return self._call(lambda: self.simulator.latest_scan)

    async def get_sensors_info(self) -> list[BasicSensorInfo]:
        return self._call(self.simulator.sensors_info)

    async def get_sensor_values(self) -> dict[int, BasicSensorValue]:
        return self._call(self.simulator.sensor_values)

    async def get_device_info(self) -> DeviceInfo:
        return self._call(self.simulator.device_info)

    async def get_health(self) -> HealthInfo:
        return self._call(self.simulator.health)

    async def clear_health_error(self, error_code: int) -> bool:
        return self._call(self.simulator.clear_health_error, error_code)

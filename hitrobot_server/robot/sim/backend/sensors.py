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
from ..runner import RunnerPart


class SimSensors(RunnerPart, SensorBackend):
    async def get_odometry(self) -> Odometry:
        return self.runner.call(self.runner.simulator.odometry)

    async def get_laser_scan(self) -> LaserScan:
        return self.runner.call(lambda: self.runner.simulator.latest_scan)

    async def get_sensors_info(self) -> list[BasicSensorInfo]:
        return self.runner.call(self.runner.simulator.sensors_info)

    async def get_sensor_values(self) -> dict[int, BasicSensorValue]:
        return self.runner.call(self.runner.simulator.sensor_values)

    async def get_device_info(self) -> DeviceInfo:
        return self.runner.call(self.runner.simulator.device_info)

    async def get_health(self) -> HealthInfo:
        return self.runner.call(self.runner.simulator.health)

    async def clear_health_error(self, error_code: int) -> bool:
        return self.runner.call(self.runner.simulator.clear_health_error, error_code)

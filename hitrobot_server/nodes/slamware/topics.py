"""The Slamware node's topic names, as its parameters set them (relative names live under the
node), and the message package of its own types."""

from __future__ import annotations

from dataclasses import dataclass

from ..ground import messages as m
from ..ground.names import SLAMWARE_NODE
from ..ground.slamware_params import SlamwareParams

NODE_NAME = SLAMWARE_NODE
PKG = "slamware_ros_sdk"


def with_alias(topic: str, alias: str) -> tuple[str, ...]:
    """The node's own topic, plus its conventional name when set and different."""
    alias = m.slamware_topic(alias) if alias else ""
    return (topic, alias) if alias and alias != topic else (topic,)


def global_names(p: SlamwareParams) -> tuple[str, ...]:
    """The node's name and every topic its parameters name (relative ones under the node)."""
    topics = [v for k, v in p.as_dict().items() if k.endswith("_topic") and v]
    return (NODE_NAME, *(m.slamware_topic(t) for t in topics))


@dataclass(frozen=True)
class SlamwareTopics:
    """Where the node publishes: one name per topic (two for scan and odometry when their
    conventional names are on)."""

    scan: tuple[str, ...]
    odom: tuple[str, ...]
    map: str
    map_info: str
    sensors_info: str
    sensors_values: str
    path: str
    state: str = m.slamware_topic("robot_basic_state")
    walls: str = m.slamware_topic("virtual_walls")
    tracks: str = m.slamware_topic("virtual_tracks")
    device: str = m.slamware_topic("robot_device_info")

    @classmethod
    def of(cls, p: SlamwareParams) -> SlamwareTopics:
        return cls(
            scan=with_alias(m.slamware_topic(p.scan_topic), p.conventional_scan_topic),
            odom=with_alias(m.slamware_topic(p.odom_topic), p.conventional_odom_topic),
            map=m.slamware_topic(p.map_topic),
            map_info=m.slamware_topic(p.map_info_topic),
            sensors_info=m.slamware_topic(p.basic_sensors_info_topic),
            sensors_values=m.slamware_topic(p.basic_sensors_values_topic),
            path=m.slamware_topic(p.path_topic),
        )

    def advertised(self) -> list[tuple[str, str, bool]]:
        """(topic, type, latched) of every topic the node publishes."""
        return [
            *((t, "sensor_msgs/LaserScan", False) for t in self.scan),
            *((t, "nav_msgs/Odometry", False) for t in self.odom),
            (self.map, "nav_msgs/OccupancyGrid", True),
            (self.map_info, "nav_msgs/MapMetaData", True),
            (self.sensors_info, f"{PKG}/BasicSensorInfoArray", True),
            (self.sensors_values, f"{PKG}/BasicSensorValueDataArray", False),
            (self.path, "nav_msgs/Path", False),
            (self.state, f"{PKG}/RobotBasicState", True),
            (self.walls, f"{PKG}/Line2DFlt32Array", True),
            (self.tracks, f"{PKG}/Line2DFlt32Array", True),
            (self.device, f"{PKG}/RobotDeviceInfo", True),
        ]

"""The node's parameters (seed §4), with the real node's defaults.

They are set at start from the ``[slamware]`` table of the TOML config, and mirrored onto the
parameter server under ``/slamware_ros_sdk_server_node/`` so rosapi clients can read them.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

from ...robot.options import RECONN_WAIT_MS


@dataclass
class SlamwareParams:
    ip_address: str = "192.168.11.1"
    robot_port: int = 1445
    reconn_wait_ms: int = RECONN_WAIT_MS
    angle_compensate: bool = True
    fixed_odom_map_tf: bool = True
    robot_frame: str = "/base_link"
    laser_frame: str = "/laser"
    odom_frame: str = "/odom"
    map_frame: str = "/map"
    robot_pose_pub_period: float = 0.05
    scan_pub_period: float = 0.1
    map_update_period: float = 0.2
    map_pub_period: float = 0.2
    basic_sensors_info_update_period: float = 7.0
    basic_sensors_values_pub_period: float = 0.05
    path_pub_period: float = 0.05
    robot_basic_state_pub_period: float = 1.0
    virtual_walls_pub_period: float = 0.5
    virtual_tracks_pub_period: float = 0.5
    map_sync_once_get_max_wh: float = 100.0
    map_update_near_robot_half_wh: float = 8.0
    scan_topic: str = "scan"
    odom_topic: str = "odom"
    map_topic: str = "map"
    map_info_topic: str = "map_metadata"
    basic_sensors_info_topic: str = "basic_sensors_info"
    basic_sensors_values_topic: str = "basic_sensors_values"
    path_topic: str = "global_plan_path"
    vel_control_topic: str = "/cmd_vel"
    goal_topic: str = "/move_base_simple/goal"
    # ours: the same scan and odometry also on the conventional names generic ROS tools
    # (rviz, Foxglove, ros3djs examples) look for; "" turns an alias off
    conventional_scan_topic: str = "/scan"
    conventional_odom_topic: str = "/odom"

    @classmethod
    def from_mapping(cls, values: dict[str, Any]) -> SlamwareParams:
        """Build from a config table; unknown names and wrong types are errors, not surprises."""
        known = {f.name: f for f in fields(cls)}
        out: dict[str, Any] = {}
        for key, value in values.items():
            name = key.replace("-", "_")
            if name not in known:
                raise ValueError(f"[slamware]: unknown parameter '{key}'")
            default = known[name].default
            if isinstance(default, bool):
                ok = isinstance(value, bool)
            elif isinstance(default, float):
                ok = isinstance(value, int | float) and not isinstance(value, bool)
                value = float(value)
            elif isinstance(default, int):
                ok = isinstance(value, int) and not isinstance(value, bool)
            else:
                ok = isinstance(value, str)
            if not ok:
                raise ValueError(
                    f"[slamware]: parameter '{key}' must be {type(default).__name__}, "
                    f"got {value!r}"
                )
            out[name] = value
        return cls(**out)

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

"""Which robot to attach and how; the command line builds it."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class RobotOptions:
    robot: str = "sim"  # 'sim', 'none' or a Slamware REST URL
    world: str | None = None  # map_server YAML the simulator drives in (None: the office)
    sim_seed: int = 0
    sim_speed: float = 1.0
    sim_mapping: bool = False
    reconn_wait_ms: int = 3000  # the REST client's wait between reconnection attempts

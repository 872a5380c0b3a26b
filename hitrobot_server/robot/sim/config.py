"""A simulator's rates, budgets and sub-configurations: a module of its own, so the parts of
the simulator (commands, maps, snapshot) can name it without importing the simulator."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..planning.costmap import CostmapConfig
from ..planning.matching import LocalizationConfig
from .kinematics import DriveLimits
from .lidar import LidarConfig
from .power import PowerConfig


@dataclass(frozen=True, slots=True)
class SimConfig:
    """Rates, budgets and sub-configurations of a :class:`Simulator`."""

    tick: float = 0.025
    scan_period: float = 0.1
    map_period: float = 0.2
    velocity_timeout: float = 0.5
    plan_budget: int = 2000
    match_budget: int = 400_000
    initial_battery: float = 80.0
    prebuilt_map: bool = True
    map_update: bool = False
    drive: DriveLimits = field(default_factory=DriveLimits)
    lidar: LidarConfig = field(default_factory=LidarConfig)
    costmap: CostmapConfig = field(default_factory=CostmapConfig)
    localization: LocalizationConfig = field(default_factory=LocalizationConfig)
    power: PowerConfig = field(default_factory=PowerConfig)

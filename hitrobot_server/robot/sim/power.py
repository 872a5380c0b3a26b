"""Battery and dock: drain with time and motion, charge while sitting on the dock.

Docking is physical: the robot charges when its *true* pose is on the world's dock, whatever it
believes; a robot that "docks" at a wrong believed pose does not charge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..model import DockingStatus, Pose2D, PowerStatus
from ..planning.geometry import wrap_angle


@dataclass(frozen=True, slots=True)
class PowerConfig:
    """Rates in percent per second; tolerances in metres / radians."""

    idle_drain: float = 0.004
    motion_drain: float = 0.03
    charge_rate: float = 0.25
    low_battery: float = 15.0
    dock_tolerance: float = 0.1
    dock_yaw_tolerance: float = 0.25


def on_dock(true_pose: Pose2D, dock: Pose2D | None, config: PowerConfig) -> bool:
    """Whether the robot's charging contacts touch the dock."""
    if dock is None:
        return False
    close = math.hypot(true_pose.x - dock.x, true_pose.y - dock.y) < config.dock_tolerance
    return close and abs(wrap_angle(true_pose.yaw - dock.yaw)) < config.dock_yaw_tolerance


class Battery:
    """State of charge in percent."""

    def __init__(self, percentage: float, config: PowerConfig) -> None:
        self.percentage = max(0.0, min(100.0, percentage))
        self.config = config

    def set(self, percent: float) -> float:
        """Set the state of charge (0–100 %, else ``ValueError``); returns what it is now."""
        if not (math.isfinite(percent) and 0.0 <= percent <= 100.0):
            raise ValueError("percent must be between 0 and 100")
        self.percentage = float(percent)
        return self.percentage

    def step(self, dt: float, effort: float, docked: bool) -> None:
        """Advance ``dt`` seconds; ``effort`` is 0 (still) to 1 (full speed)."""
        cfg = self.config
        if docked:
            self.percentage = min(100.0, self.percentage + cfg.charge_rate * dt)
        else:
            drain = cfg.idle_drain + cfg.motion_drain * min(1.0, max(0.0, effort))
            self.percentage = max(0.0, self.percentage - drain * dt)

    @property
    def low(self) -> bool:
        return self.percentage < self.config.low_battery

    def status(self, docked: bool) -> PowerStatus:
        return PowerStatus(
            battery_percentage=int(round(self.percentage)),
            is_charging=docked and self.percentage < 100.0,
            is_dc_in=docked,
            docking_status=DockingStatus.ON_DOCK if docked else DockingStatus.NOT_ON_DOCK,
        )

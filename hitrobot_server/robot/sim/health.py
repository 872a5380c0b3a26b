"""The simulated robot's health report: warnings and errors that come and go with the robot's
condition, each with a fresh id when it (re)appears, as on the REST API."""

from __future__ import annotations

from ..model import HealthComponent, HealthError, HealthInfo, HealthLevel, health_error_code
from .controls import EMERGENCY_STOP, EMERGENCY_STOP_MESSAGE

LOW_QUALITY = 30
"""Localization quality below which health reports an error."""

POWER_LOW = health_error_code(HealthLevel.WARN, HealthComponent.POWER, 0x0100)
LOCALIZATION_LOW = health_error_code(HealthLevel.ERROR, HealthComponent.SYSTEM, 0x0900)
RELOCALIZATION_FAILED = health_error_code(HealthLevel.ERROR, HealthComponent.SYSTEM, 0x0800)


class HealthMonitor:
    """The active errors of one simulated robot."""

    def __init__(self) -> None:
        self._health: dict[int, HealthError] = {}
        self._next_health_id = 1
        self.relocalization_failed = False
        """Whether the last relocalization failed (until acknowledged or one succeeds)."""
        self.emergency_stop = False
        """Whether the (simulated) emergency stop is pressed: a FATAL error until released."""

    def report(self, power_low: bool, localization_enabled: bool, quality: int) -> HealthInfo:
        """The errors active for this condition of the robot."""
        active = {
            POWER_LOW: (power_low, HealthComponent.POWER, HealthLevel.WARN, "power low"),
            LOCALIZATION_LOW: (
                localization_enabled and quality < LOW_QUALITY,
                HealthComponent.SYSTEM,
                HealthLevel.ERROR,
                "low localization quality",
            ),
            RELOCALIZATION_FAILED: (
                self.relocalization_failed,
                HealthComponent.SYSTEM,
                HealthLevel.ERROR,
                "relocalization failed",
            ),
            EMERGENCY_STOP: (self.emergency_stop, HealthComponent.MOTION, HealthLevel.FATAL,
                             EMERGENCY_STOP_MESSAGE),
        }
        for code, (on, component, level, message) in active.items():
            if on and code not in self._health:
                self._health[code] = HealthError(
                    self._next_health_id, component, level, code, message
                )
                self._next_health_id += 1
            elif not on:
                self._health.pop(code, None)
        return HealthInfo.from_errors(tuple(self._health.values()))

    def clear(self, error_code: int) -> bool:
        """Acknowledge an error; conditions that still hold are reported again."""
        if error_code == RELOCALIZATION_FAILED:
            self.relocalization_failed = False
        return self._health.pop(error_code, None) is not None

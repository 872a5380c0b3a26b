"""What app developers (and our tests) do to a simulated robot that no real robot offers: set
its battery, kidnap it (move its true pose; its localization is not told and has to notice),
press and release its emergency stop.

The emergency stop is reported the way a Slamware robot reports one: a FATAL health error of the
motion component (``robot/health``), so the Slamware node's health, ``/diagnostics_agg``'s
``/Robot/Health`` and the fleet see it; while it is pressed the running action is aborted
("emergency stop") on every tick and the wheels do not turn.
"""

from __future__ import annotations

import math

from ..model import ActionResult, HealthComponent, HealthLevel, Pose2D, health_error_code

EMERGENCY_STOP = health_error_code(HealthLevel.FATAL, HealthComponent.MOTION, 0x0001)
EMERGENCY_STOP_MESSAGE = "emergency stop pressed"


class SimControls:
    """Mixed into the simulator: the controls over its battery, true pose and stop button."""

    def set_battery(self, percent: float) -> float:
        """Set the state of charge (0–100 %); returns what it is now."""
        if not (math.isfinite(percent) and 0.0 <= percent <= 100.0):
            raise ValueError("percent must be between 0 and 100")
        self._battery.percentage = float(percent)
        return self._battery.percentage

    def kidnap(self, true_pose: Pose2D) -> None:
        """Carry the robot to ``true_pose`` without telling it: its believed pose stays where it
        was, so its scans stop matching the map and its localization quality falls."""
        if not all(math.isfinite(v) for v in (true_pose.x, true_pose.y, true_pose.yaw)):
            raise ValueError("pose must be finite")
        if self._clearance(true_pose.x, true_pose.y) <= self.config.drive.radius:
            raise ValueError(f"({true_pose.x:.2f}, {true_pose.y:.2f}) is not free floor")
        believed = self.pose
        self._actions_abort("kidnapped")
        self._drive.pose = true_pose
        self._localizer.set_pose(believed, true_pose)

    @property
    def emergency_stopped(self) -> bool:
        return self._health.emergency_stop

    def emergency_stop(self, pressed: bool) -> None:
        """Press (``True``) or release the emergency stop."""
        self._health.emergency_stop = bool(pressed)
        if pressed:
            self._actions_abort("emergency stop")

    def _actions_abort(self, reason: str) -> None:
        current = self._actions.running()
        if current is not None:
            current.finish(ActionResult.ABORTED, reason)
        self._drive.linear = self._drive.angular = 0.0

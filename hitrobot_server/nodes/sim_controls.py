"""The simulator's controls on the bus, for app developers' screens and our tests (a simulated
robot only; a REST robot has none of these names).

* ``/sim/set_battery`` (``hitrobot_msgs/SimSetBattery``): the state of charge, 0–100 %.
* ``/sim/kidnap`` (``hitrobot_msgs/SimKidnap``): move the true pose; the robot is not told, its
  localization quality falls by itself. A zero or non-normalisable quaternion is refused (the
  pose is a place the robot is carried to, not a goal, so there is no "yaw 0" default).
* ``/sim/emergency_stop`` (``std_srvs/SetBool``): press (``true``) or release the stop; a
  pressed stop is the Slamware health error "emergency stop pressed" (FATAL, motion), seen on
  ``/diagnostics_agg`` (``/Robot/Health``) and by the fleet, and aborts whatever the robot does.

A named robot's are under ``/NAME/sim/``.
"""

from __future__ import annotations

from ..bus.core import Bus
from ..bus.topics import RequestRejected
from ..robot.backend import BackendError, Link
from ..robot.sim.backend.controls import SimControls
from .base import RobotNode
from .ground import messages as m

SET_BATTERY, KIDNAP, EMERGENCY_STOP = "/sim/set_battery", "/sim/kidnap", "/sim/emergency_stop"


class SimControlsNode(RobotNode):
    """``/sim/set_battery``, ``/sim/kidnap``, ``/sim/emergency_stop``."""

    GLOBAL_NAMES = ("/sim",)

    def __init__(self, bus: Bus, link: Link, controls: SimControls):
        super().__init__(bus, "/sim", link)
        self.controls = controls
        self.service(SET_BATTERY, "hitrobot_msgs/SimSetBattery", self._set_battery)
        self.service(KIDNAP, "hitrobot_msgs/SimKidnap", self._kidnap)
        self.service(EMERGENCY_STOP, "std_srvs/SetBool", self._emergency_stop)

    async def _set_battery(self, request: dict) -> dict:
        try:
            now = self.controls.set_battery(float(request["percent"]))
        except BackendError as exc:
            return {"success": False, "message": f"percent: {exc}"}
        return {"success": True, "message": f"battery at {now:.1f} %"}

    async def _kidnap(self, request: dict) -> dict:
        try:
            pose = m.unit_pose2d_of(request["pose"], "pose")
            self.controls.kidnap(pose)
        except (RequestRejected, BackendError) as exc:
            return {"success": False, "message": str(exc)}
        return {"success": True, "message": f"carried to ({pose.x:.2f}, {pose.y:.2f}); "
                "the robot was not told"}

    async def _emergency_stop(self, request: dict) -> dict:
        pressed = bool(request["data"])
        try:
            self.controls.emergency_stop(pressed)
        except BackendError as exc:
            return {"success": False, "message": str(exc)}
        return {"success": True,
                "message": "emergency stop pressed" if pressed else "emergency stop released"}

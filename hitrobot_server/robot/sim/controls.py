"""What app developers (and our tests) do to a simulated robot that no real robot offers: set
its battery, kidnap it (move its true pose; its localization is not told and has to notice),
press and release its emergency stop (:class:`~.simulator.Simulator`'s ``set_battery``,
``kidnap``, ``emergency_stop``; :mod:`.backend.controls` for the bus).

The emergency stop is reported the way a Slamware robot reports one: a FATAL health error of the
motion component (``robot/health``), so the Slamware node's health, ``/diagnostics_agg``'s
``/Robot/Health`` and the fleet see it; while it is pressed the running action is aborted
("emergency stop") on every tick and the wheels do not turn.
"""

from __future__ import annotations

from ..model import HealthComponent, HealthLevel, health_error_code

EMERGENCY_STOP = health_error_code(HealthLevel.FATAL, HealthComponent.MOTION, 0x0001)
EMERGENCY_STOP_MESSAGE = "emergency stop pressed"

"""What a vehicle reports of its robot, read through the robot's capabilities (the same calls
the fleet's member node makes): pose, localization, velocity, battery, faults, the motion
running. Reading is all it does; the robot is moved only over the bus (``driver``)."""

from __future__ import annotations

from dataclasses import replace

from ..robot.backend import BackendError
from ..robot.capabilities import Robot
from ..robot.model import HealthLevel
from . import errors as e
from .messages import Reading

LOCALIZED_FROM = 30
"""A localization quality (0-100) from which the position counts as initialized."""


async def read(robot: Robot, last: Reading) -> tuple[Reading, list[dict], bool]:
    """The robot now: its reading, its faults as ``state.errors`` entries, and whether some
    motion runs on it (ours or anyone's). Offline: the last pose, marked not initialized."""
    if not robot.link.connected:
        return replace(last, online=False, localized=False, driving=False, vx=0.0,
                       omega=0.0), [e.error(e.ROBOT, "the robot is not connected", e.FATAL)], \
            False
    try:
        pose = await robot.localization.get_pose()
        quality = await robot.localization.get_localization_quality()
        odometry = await robot.sensors.get_odometry()
        power = await robot.power.get_power_status()
        health = await robot.sensors.get_health()
        action = await robot.motion.get_current_action()
    except BackendError as exc:
        return replace(last, online=False), [e.error(e.ROBOT, f"the robot does not answer: "
                                                     f"{exc}", e.FATAL)], False
    moving = abs(odometry.twist.vx) > 0.01 or abs(odometry.twist.omega) > 0.02
    reading = Reading(
        x=pose.x, y=pose.y, theta=pose.yaw, vx=odometry.twist.vx, omega=odometry.twist.omega,
        battery=float(power.battery_percentage), charging=bool(power.is_charging),
        localization=max(0.0, min(1.0, quality / 100.0)), localized=quality >= LOCALIZED_FROM,
        driving=action is not None and moving, online=True,
        e_stop=any("emergency" in h.message.lower() for h in health.errors))
    faults = [e.error(e.ROBOT, h.message or f"robot fault {h.error_code}",
                      e.FATAL if h.level >= HealthLevel.FATAL else e.WARNING,
                      errorCode=h.error_code)
              for h in health.errors if h.level >= HealthLevel.ERROR]
    if not reading.localized:
        faults.append(e.error(e.LOCALIZATION, f"localization quality {quality} is under "
                              f"{LOCALIZED_FROM}: the robot's position is not known"))
    return reading, faults, action is not None

"""Basic sensors: three bumpers, two cliff sensors and three front sonars.

Bumpers latch for a short hold time after a collision so a 20 Hz poller cannot miss them. The
floor of a 2D world has no drops, so cliff sensors never fire. Sonars reuse the lidar's caster
with a small fan of rays per sonar, reporting the nearest echo.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np

from ... import __version__
from ..model import BasicSensorInfo, BasicSensorValue, DeviceInfo, ImpactType, Pose2D, SensorType
from .lidar import RayCaster

BUMPER_HOLD = 0.5
"""Seconds a bumper stays triggered after the last contact."""
SONAR_RANGE = 2.0
SONAR_HALF_CONE = math.radians(12.0)
_SONAR_RAYS = 5

# (id, type, impact, mount bearing, refresh Hz)
_LAYOUT = [
    (0, SensorType.BUMPER, ImpactType.DIGITAL, math.radians(45.0), 50.0),
    (1, SensorType.BUMPER, ImpactType.DIGITAL, math.radians(-45.0), 50.0),
    (2, SensorType.BUMPER, ImpactType.DIGITAL, math.pi, 50.0),
    (3, SensorType.CLIFF, ImpactType.DIGITAL, math.radians(30.0), 50.0),
    (4, SensorType.CLIFF, ImpactType.DIGITAL, math.radians(-30.0), 50.0),
    (5, SensorType.SONAR, ImpactType.ANALOG, math.radians(30.0), 10.0),
    (6, SensorType.SONAR, ImpactType.ANALOG, 0.0, 10.0),
    (7, SensorType.SONAR, ImpactType.ANALOG, math.radians(-30.0), 10.0),
]


class SensorSuite:
    """Sensor layout and current readings."""

    def __init__(self, caster: RayCaster, radius: float) -> None:
        self._caster = caster
        self.info = [
            BasicSensorInfo(
                sid,
                kind,
                impact,
                Pose2D(radius * math.cos(bearing), radius * math.sin(bearing), bearing),
                freq,
            )
            for sid, kind, impact, bearing, freq in _LAYOUT
        ]
        self._bumped_until = {0: -math.inf, 1: -math.inf, 2: -math.inf}
        self._sonar = {5: SONAR_RANGE, 6: SONAR_RANGE, 7: SONAR_RANGE}
        self._sonar_mounts = [(s.id, s.install_pose) for s in self.info[5:]]
        self._fan = np.linspace(-SONAR_HALF_CONE, SONAR_HALF_CONE, _SONAR_RAYS)

    def bump(self, bearing: float, now: float) -> None:
        """Register a contact at ``bearing`` (relative to the heading)."""
        if abs(bearing) > math.radians(100.0):
            hit = [2]
        elif abs(bearing) < math.radians(15.0):
            hit = [0, 1]
        else:
            hit = [0] if bearing > 0 else [1]
        for sid in hit:
            self._bumped_until[sid] = now + BUMPER_HOLD

    def bumper_active(self, now: float) -> bool:
        return any(until > now for until in self._bumped_until.values())

    def update_sonars(self, pose: Pose2D) -> None:
        """Measure the sonars from the true pose."""
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        ox, oy, angles = [], [], []
        for _, mount in self._sonar_mounts:
            ox.append(pose.x + c * mount.x - s * mount.y)
            oy.append(pose.y + s * mount.x + c * mount.y)
            angles.append(pose.yaw + mount.yaw + self._fan)
        n = len(self._fan)
        ranges = self._caster.cast(
            np.repeat(ox, n), np.repeat(oy, n), np.concatenate(angles), SONAR_RANGE
        )
        nearest = np.minimum(ranges.reshape(-1, n).min(axis=1), SONAR_RANGE)
        for (sid, _), value in zip(self._sonar_mounts, nearest, strict=True):
            self._sonar[sid] = float(value)

    def values(self, now: float) -> dict[int, BasicSensorValue]:
        """Readings keyed by id, in the conventions of :class:`BasicSensorValue`."""
        out: dict[int, BasicSensorValue] = {}
        for sid, until in self._bumped_until.items():
            pressed = until > now
            out[sid] = BasicSensorValue(pressed, 0.0 if pressed else 1.0)
        out[3] = BasicSensorValue(False, 1.0)
        out[4] = BasicSensorValue(False, 1.0)
        for sid, value in self._sonar.items():
            out[sid] = BasicSensorValue(True, value)
        return dict(sorted(out.items()))


def device_info(seed: int) -> DeviceInfo:
    """The identity of the simulated robot with ``seed``: a device id of its own per seed."""
    digest = hashlib.md5(f"hitrobot-sim-{seed}".encode(), usedforsecurity=False)
    return DeviceInfo(
        device_id=digest.hexdigest().upper(),
        model_id=0,
        model_name="hitrobot-sim",
        manufacturer_id=0,
        manufacturer_name="hitrobot",
        hardware_version="sim",
        software_version=__version__,
        sdp_version=__version__,
        sdk_version=__version__,
    )

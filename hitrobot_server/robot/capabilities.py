"""One robot as the nodes get it: its capabilities, each a narrow protocol, with the motion
behind the locomotion gate.

A node asks for the capabilities it uses (``robot.motion``, ``robot.localization``, …), never
for the whole backend; :func:`~hitrobot_server.robot.factory.robot_of` builds the bundle from a
backend, and ``nodes/assembly.py`` hands each node its part.
"""

from __future__ import annotations

from dataclasses import dataclass

from .backend import (
    Link,
    LocalizationBackend,
    MapBackend,
    MotionBackend,
    PowerBackend,
    SensorBackend,
)
from .locomotion import Locomotion


@dataclass(frozen=True, slots=True)
class Robot:
    """One robot's capabilities. ``motion`` is gated by ``locomotion`` (a sitting robot
    refuses it whichever node asks); everything else is the backend's own."""

    link: Link
    motion: MotionBackend
    localization: LocalizationBackend
    maps: MapBackend
    sensors: SensorBackend
    power: PowerBackend
    locomotion: Locomotion

    @property
    def connected(self) -> bool:
        return self.link.connected

    @property
    def simulator(self):
        """The simulator behind a simulated robot (sim tools and tests reach it here); an
        ``AttributeError`` when the robot is not simulated."""
        return self.link.simulator  # type: ignore[attr-defined]

    async def reboot(self) -> None:
        """Restart the robot (``/cmd_string reboot``): it goes offline now and comes back
        with a fresh state, its locomotion as freshly started."""
        await self.power.reboot()
        self.locomotion.restarted()

"""``ComposedBackend``: one robot backend, one adapter per capability.

Every backend is built this way: the Slamware REST client (:mod:`.rest`: one adapter per
protocol over a shared ``RestLink``) and the simulator (:mod:`.sim.backend`: one adapter per
protocol over its ``SimRunner``). Nothing is forwarded: the server starts and stops a robot
through its ``link``; the nodes, tools and tests get the adapters themselves, bundled in a
:class:`~.capabilities.Robot` by :func:`~.factory.robot_of` (the motion behind the
locomotion gate).
"""

from __future__ import annotations

from collections.abc import Sequence

from .backend import (
    Link,
    LocalizationBackend,
    MapBackend,
    MotionBackend,
    PowerBackend,
    SensorBackend,
)


class ComposedBackend:
    """Every capability of one robot, each served by its own adapter. ``restored``: what
    the backend took back from its state folder, as phrases for the start-up log (a REST robot
    keeps its own state: none)."""

    def __init__(self, link: Link, motion: MotionBackend, localization: LocalizationBackend,
                 maps: MapBackend, sensors: SensorBackend, power: PowerBackend,
                 restored: Sequence[str] = ()) -> None:
        self.link = link
        self.motion = motion
        self.localization = localization
        self.maps = maps
        self.sensors = sensors
        self.power = power
        self.restored = list(restored)

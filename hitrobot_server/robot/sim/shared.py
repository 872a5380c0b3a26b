"""One simulated world for several robots: they see each other in their lidar and planners,
never drive through each other, and each starts at its own free spot.

Each robot keeps its own :class:`Simulator` (own seed, map, battery, actions); the world's
ground truth is shared, and every simulator asks :meth:`SharedWorld.others` for the true poses
of the other robots when it senses, moves or plans.
"""

from __future__ import annotations

import math

import numpy as np

from ..model import Pose2D
from ..planning.grid import distance_field
from .backend import SimBackend
from .config import SimConfig
from .persist import SimMemory
from .simulator import Simulator
from .world import World

SPACING = 1.0
"""Centre-to-centre distance (m) an automatically chosen start keeps from the other robots."""


class SharedWorld:
    """The world several :class:`SimBackend` robots drive in."""

    def __init__(self, world: World, config: SimConfig | None = None):
        self.world = world
        self.config = config or SimConfig()
        self.robots: list[SimBackend] = []
        radius = self.config.drive.radius
        res = world.spec.resolution
        clearance = distance_field(world.solid, math.ceil(1.0 / res) + 1) * res
        self._standable = clearance >= radius + 0.5 * res + self.config.costmap.safety_margin
        self._standable &= clearance >= radius + 0.3  # room to turn around at the start

    def others(self, me: Simulator) -> list[Pose2D]:
        return [b.runner.simulator.true_pose for b in self.robots if b.runner.simulator is not me]

    def add(self, seed: int, start: Pose2D | None, time_scale: float,
            memory: SimMemory | None = None) -> SimBackend:
        """A new robot at ``start`` (checked: free and clear of the others) or, without one,
        at the free spot nearest the world's start pose; ``memory``: where its map, lines and
        pose survive a restart (restored over the start pose)."""
        pose = self._checked(start) if start is not None else self._free_spot()
        simulator = Simulator(self.world, seed=seed, config=self.config, start=pose,
                              others=self.others)
        backend = SimBackend(simulator, time_scale=time_scale, memory=memory)
        self.robots.append(backend)
        return backend

    def _taken(self) -> list[Pose2D]:
        return [b.runner.simulator.true_pose for b in self.robots]

    def _checked(self, start: Pose2D) -> Pose2D:
        spec = self.world.spec
        ix, iy = spec.cell(start.x, start.y)
        if not spec.contains(ix, iy) or not self._standable[iy, ix]:
            raise ValueError(f"start pose ({start.x:g}, {start.y:g}) is not a free spot in the "
                             f"world '{self.world.name}'")
        for other in self._taken():
            gap = math.hypot(other.x - start.x, other.y - start.y)
            if gap < 2 * self.config.drive.radius + 0.1:
                raise ValueError(f"start pose ({start.x:g}, {start.y:g}) is on another robot "
                                 f"(at {other.x:.2f}, {other.y:.2f})")
        return start

    def _free_spot(self) -> Pose2D:
        spec = self.world.spec
        home = self.world.start_pose
        xs, ys = spec.center(np.arange(spec.width)[None, :], np.arange(spec.height)[:, None])
        ok = self._standable.copy()
        for other in self._taken():
            ok &= np.hypot(xs - other.x, ys - other.y) >= SPACING
        if not ok.any():
            raise ValueError(f"no free start spot left in the world '{self.world.name}'")
        distance = np.where(ok, np.hypot(xs - home.x, ys - home.y), np.inf)
        row, col = np.unravel_index(int(np.argmin(distance)), distance.shape)
        x, y = spec.center(col, row)
        return Pose2D(float(x), float(y), home.yaw)

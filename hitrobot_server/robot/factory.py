"""Which robot backs the bus: the built-in simulator, or none (bridge only)."""

from __future__ import annotations

from ..config import Settings
from .backend import RobotBackend


def build_backend(settings: Settings) -> RobotBackend | None:
    """The robot backend for ``--robot``; the caller starts and stops it."""
    if settings.robot == "none":
        return None
    if settings.robot != "sim":
        raise ValueError(f"--robot {settings.robot}: the Slamware REST client is not built yet")
    from .sim.backend import SimBackend
    from .sim.simulator import SimConfig, Simulator
    from .sim.world import load_world

    world = load_world(settings.world) if settings.world else load_world()
    config = SimConfig(prebuilt_map=not settings.sim_mapping, map_update=settings.sim_mapping)
    simulator = Simulator(world, seed=settings.sim_seed, config=config)
    return SimBackend(simulator, time_scale=settings.sim_speed)

"""Which robot backs the bus: the built-in simulator, a Slamware robot over REST, or none."""

from __future__ import annotations

from ..config import Settings
from .backend import RobotBackend


def build_simulator(world: str | None = None, seed: int = 0, mapping: bool = False):
    """The built-in simulated robot (``--world``, ``--sim-seed``, ``--sim-mapping``)."""
    from .sim.simulator import SimConfig, Simulator
    from .sim.world import load_world

    loaded = load_world(world) if world else load_world()
    config = SimConfig(prebuilt_map=not mapping, map_update=mapping)
    return Simulator(loaded, seed=seed, config=config)


def build_backend(settings: Settings) -> RobotBackend | None:
    """The robot backend for ``--robot``; the caller starts and stops it."""
    if settings.robot == "none":
        return None
    if settings.robot.startswith(("http://", "https://")):
        from .rest.client import SlamwareRestBackend

        return SlamwareRestBackend(settings.robot, settings.slamware.reconn_wait_ms)
    if settings.robot != "sim":
        raise ValueError(f"--robot {settings.robot}: expected sim, none or an http(s):// URL")
    from .sim.backend import SimBackend

    simulator = build_simulator(settings.world, settings.sim_seed, settings.sim_mapping)
    return SimBackend(simulator, time_scale=settings.sim_speed)

"""Which robot backs the bus: the built-in simulator, a Slamware robot over REST, or none."""

from __future__ import annotations

from .backend import RobotBackend
from .options import RobotOptions


def build_simulator(world: str | None = None, seed: int = 0, mapping: bool = False):
    """The built-in simulated robot (``--world``, ``--sim-seed``, ``--sim-mapping``)."""
    from .sim.simulator import SimConfig, Simulator
    from .sim.world import load_world

    loaded = load_world(world) if world else load_world()
    config = SimConfig(prebuilt_map=not mapping, map_update=mapping)
    return Simulator(loaded, seed=seed, config=config)


def build_backend(options: RobotOptions) -> RobotBackend | None:
    """The robot backend for ``--robot``; the caller starts and stops it."""
    if options.robot == "none":
        return None
    if options.robot.startswith(("http://", "https://")):
        from .rest.client import SlamwareRestBackend

        return SlamwareRestBackend(options.robot, options.reconn_wait_ms)
    if options.robot != "sim":
        raise ValueError(f"--robot {options.robot}: expected sim, none or an http(s):// URL")
    from .sim.backend import SimBackend

    simulator = build_simulator(options.world, options.sim_seed, options.sim_mapping)
    return SimBackend(simulator, time_scale=options.sim_speed)

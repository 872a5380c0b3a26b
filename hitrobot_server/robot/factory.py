"""Which robot backs the bus: the built-in simulator, a Slamware robot over REST, or none."""

from __future__ import annotations

from pathlib import Path

from ..state import StateStore
from .backend import RobotBackend
from .options import RobotOptions


def build_simulator(world: str | None = None, seed: int = 0, mapping: bool = False):
    """The built-in simulated robot (``--world``, ``--sim-seed``, ``--sim-mapping``)."""
    from .sim.simulator import SimConfig, Simulator
    from .sim.world import load_world

    loaded = load_world(world) if world else load_world()
    config = SimConfig(prebuilt_map=not mapping, map_update=mapping)
    return Simulator(loaded, seed=seed, config=config)


def sim_identity(options: RobotOptions) -> str:
    """The simulated robot's identity (its state folder): one per world, so a robot that
    drives in another world never finds this one's walls and pose."""
    return "sim-" + (Path(options.world).stem if options.world else "office")


def build_backend(options: RobotOptions, state: StateStore | None = None) -> RobotBackend | None:
    """The robot backend for ``--robot``; the caller starts and stops it. ``state``: the
    simulator's state folder (a REST robot keeps its own map, lines and pose)."""
    if options.robot == "none":
        return None
    if options.robot.startswith(("http://", "https://")):
        from .rest.client import SlamwareRestBackend

        return SlamwareRestBackend(options.robot, options.reconn_wait_ms)
    if options.robot != "sim":
        raise ValueError(f"--robot {options.robot}: expected sim, none or an http(s):// URL")
    from .sim.backend import SimBackend
    from .sim.persist import SimMemory

    simulator = build_simulator(options.world, options.sim_seed, options.sim_mapping)
    memory = SimMemory(state) if state is not None else None
    return SimBackend(simulator, time_scale=options.sim_speed, memory=memory)

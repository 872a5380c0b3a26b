"""Which robot backs the bus (the built-in simulator, a Slamware robot over REST, or none),
and the capabilities the nodes get of it (:func:`robot_of`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..state import StateStore
from .capabilities import Robot
from .composed import ComposedBackend
from .locomotion import STAND_UP_SECONDS, GatedMotion, Locomotion
from .model import Pose2D
from .options import RobotOptions

if TYPE_CHECKING:
    from .sim.shared import SharedWorld


def _sim_config(mapping: bool):
    from .sim.config import SimConfig

    return SimConfig(prebuilt_map=not mapping, map_update=mapping)


def build_simulator(world: str | None = None, seed: int = 0, mapping: bool = False):
    """The built-in simulated robot (``--world``, ``--sim-seed``, ``--sim-mapping``)."""
    from .sim.simulator import Simulator
    from .sim.world import load_world

    loaded = load_world(world) if world else load_world()
    return Simulator(loaded, seed=seed, config=_sim_config(mapping))


def shared_world(options: RobotOptions) -> SharedWorld:
    """One world for several simulated robots (``--world``, ``--sim-mapping``)."""
    from .sim.shared import SharedWorld
    from .sim.world import load_world

    loaded = load_world(options.world) if options.world else load_world()
    return SharedWorld(loaded, _sim_config(options.sim_mapping))


def sim_identity(options: RobotOptions, name: str = "") -> str:
    """A simulated robot's identity (its state folder): one per world, and per robot name in a
    fleet, so a robot never finds another one's walls and pose."""
    world = Path(options.world).stem if options.world else "office"
    return f"sim-{world}" + (f"-{name}" if name else "")


def build_backend(options: RobotOptions, world: SharedWorld | None = None,
                  state: StateStore | None = None) -> ComposedBackend | None:
    """The robot backend for ``--robot``; the caller starts and stops it (its ``link``). A
    simulated robot joins ``world`` when one is given (its seed offset by the robots already
    there). ``state``: the simulator's state folder (a REST robot keeps its own map, lines and
    pose)."""
    if options.robot == "none":
        return None
    if options.robot.startswith(("http://", "https://")):
        from .rest.client import SlamwareRestBackend

        return SlamwareRestBackend(options.robot, options.reconn_wait_ms)
    if options.robot != "sim":
        raise ValueError(f"--robot {options.robot}: expected sim, none or an http(s):// URL")
    from .sim.backend import SimBackend
    from .sim.persist import SimMemory

    memory = SimMemory(state) if state is not None else None
    if world is not None:
        start = Pose2D(*options.start) if options.start is not None else None
        return world.add(options.sim_seed + len(world.robots), start, options.sim_speed, memory)
    simulator = build_simulator(options.world, options.sim_seed, options.sim_mapping)
    return SimBackend(simulator, time_scale=options.sim_speed, memory=memory)


def robot_of(backend: ComposedBackend, stand_up_seconds: float = STAND_UP_SECONDS) -> Robot:
    """The capabilities the nodes get of ``backend``: its adapters, except the motion, which
    goes through a fresh locomotion gate (``stand_up_seconds``: the stand-up transition)."""
    locomotion = Locomotion(backend.link, backend.motion, stand_up_seconds)
    return Robot(link=backend.link, motion=GatedMotion(backend.motion, locomotion),
                 localization=backend.localization, maps=backend.maps, sensors=backend.sensors,
                 power=backend.power, locomotion=locomotion)

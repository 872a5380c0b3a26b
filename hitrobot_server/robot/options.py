"""Which robot to attach and how.

The fields a user sets (their ``help`` in the metadata makes the flag and the TOML key, their
default is the server's) and their checks live here; ``config.py`` only composes the layers'
options, and gives each robot its own copy (its spec and start pose, :func:`dataclasses.replace`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

RECONN_WAIT_MS = 3000  # the REST client's wait between reconnection attempts ([slamware])


@dataclass(frozen=True)
class RobotOptions:
    robot: str = field(default="sim", metadata={
        "help": "the robot behind the bus: 'sim' (built-in simulated Slamware robot), 'none', "
        "or a Slamware REST URL such as http://192.168.11.1:1448; repeat as NAME=SPEC for "
        "several robots, each under /NAME/ (sim@X,Y[,YAW] sets a simulated robot's start pose)",
        "repeatable": True})
    world: str | None = field(default=None, metadata={
        "help": "map_server YAML (+ PGM) the simulator drives in (default: the built-in "
        "office)"})
    sim_seed: int = field(default=0, metadata={
        "help": "random seed of the simulator (sensor noise); same seed, same run"})
    sim_speed: float = field(default=1.0, metadata={
        "help": "simulated seconds per wall-clock second (2 = twice as fast)"})
    sim_mapping: bool = field(default=False, metadata={
        "help": "start the simulator with an empty map and mapping on (not a prebuilt map)"})
    reconn_wait_ms: int = RECONN_WAIT_MS  # from [slamware]
    start: tuple[float, float, float] | None = None  # a simulated robot's start pose (x, y, yaw)

    def check(self) -> None:
        if self.sim_speed <= 0:
            raise ValueError("sim_speed must be positive")


@dataclass(frozen=True)
class RobotEntry:
    """One ``--robot [NAME=]SPEC``: ``name`` is ``""`` for the single unnamed robot."""

    name: str
    spec: str  # 'sim', 'none' or a Slamware REST URL
    start: tuple[float, float, float] | None = None  # from 'sim@X,Y[,YAW]'

    @property
    def kind(self) -> str:
        return self.spec if self.spec in ("sim", "none") else "rest"


def parse_robot(text: str) -> RobotEntry:
    """``SPEC`` or ``NAME=SPEC``; SPEC is ``sim``, ``sim@X,Y[,YAW]`` (a start pose), ``none``
    or an ``http(s)://`` URL. Raises ``ValueError`` naming what is wrong."""
    name, spec = "", text.strip()
    head, eq, tail = spec.partition("=")
    if eq and ":" not in head and "/" not in head:
        name, spec = head.strip(), tail.strip()
        if not name:
            raise ValueError(f"--robot {text!r}: the robot name before '=' is empty")
    start = None
    if spec.startswith("sim@"):
        start = _start_pose(text, spec[4:])
        spec = "sim"
    if spec not in ("sim", "none") and not spec.startswith(("http://", "https://")):
        raise ValueError(f"--robot {text!r}: expected sim, sim@X,Y[,YAW], none or an "
                         "http(s):// URL")
    return RobotEntry(name, spec, start)


def _start_pose(text: str, pose: str) -> tuple[float, float, float]:
    try:
        values = [float(v) for v in pose.split(",")]
    except ValueError:
        values = []
    if len(values) not in (2, 3) or not all(abs(v) < 1e6 for v in values):
        raise ValueError(f"--robot {text!r}: the start pose after 'sim@' must be X,Y or X,Y,YAW")
    return (values[0], values[1], values[2] if len(values) == 3 else 0.0)

"""Which robot to attach and how; the command line builds it."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class RobotOptions:
    robot: str = "sim"  # 'sim', 'none' or a Slamware REST URL
    world: str | None = None  # map_server YAML the simulator drives in (None: the office)
    sim_seed: int = 0
    sim_speed: float = 1.0
    sim_mapping: bool = False
    reconn_wait_ms: int = 3000  # the REST client's wait between reconnection attempts
    start: tuple[float, float, float] | None = None  # a simulated robot's start pose (x, y, yaw)


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

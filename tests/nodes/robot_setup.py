"""What a tests/nodes module's ``robot`` fixture starts (``ROBOT = RobotSetup(...)``) and
what it gets (``Robot``); the fixture itself is in conftest.py."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from tests.helpers import Watcher, WsClient


@dataclass(frozen=True)
class RobotSetup:
    """What a module's ``robot`` fixture starts and waits for."""

    sim_speed: float
    watch: dict[str, str | None]  # topic → type (None: the advertised one)
    ready: Callable[[Watcher], object]  # the robot is ready when this holds
    ready_what: str
    ready_timeout: float = 10.0
    client: bool = False  # also open a raw WsClient (robot.c)
    map_dir: bool = False  # save maps under the test's tmp_path
    backends: tuple[str, ...] = ("sim",)


@dataclass
class Robot:
    server: object
    w: Watcher  # subscribed to the module's topics
    c: WsClient | None = None

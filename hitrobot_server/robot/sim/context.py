"""What a running action may see and do: the simulator's side of the action contract.

Actions only get this narrow view, so they cannot reach ground truth they should not know
(they steer by the believed pose) and can be driven by a stub in tests.
"""

from __future__ import annotations

from typing import Protocol

from ..model import LaserScan, Pose2D, Rect
from ..planning.costmap import Costmap
from ..planning.matching import RelocalizationSearch
from .kinematics import DriveLimits


class ActionContext(Protocol):
    @property
    def time(self) -> float:
        """Simulated seconds since start."""

    @property
    def pose(self) -> Pose2D:
        """The believed pose."""

    @property
    def drive(self) -> DriveLimits: ...

    @property
    def plan_budget(self) -> int:
        """A* expansions an action may spend per tick."""

    @property
    def match_budget(self) -> int:
        """Scan-match point lookups an action may spend per tick."""

    @property
    def home_pose(self) -> Pose2D | None: ...

    @property
    def docked(self) -> bool:
        """Whether the charging contacts touch the dock (a physical switch, not a belief)."""

    @property
    def latest_scan(self) -> LaserScan: ...

    def costmap(self) -> Costmap:
        """The current planning costmap (rebuilt lazily when its inputs changed)."""

    def start_relocalization(self, area: Rect | None) -> RelocalizationSearch:
        """A pose search for the latest scan."""

    @property
    def scan_odometry(self) -> Pose2D:
        """The odometry pose the latest scan was taken at (for motion since that scan)."""

    def relocalize(self, match: Pose2D, at: Pose2D) -> None:
        """Believe ``match`` was the pose at odometry pose ``at`` (plus the motion since)."""

    def report_relocalization(self, success: bool) -> None:
        """Record the outcome of a relocalization for the health report."""

"""A fleet task: what it asks (a POI or pose, a sequence of POIs with dwell times, a patrol route
for N laps, or a charge), its lifecycle and its times, as ``hitrobot_msgs/FleetTask`` and as
the record kept in the state folder.

Lifecycle: ``queued`` → ``running`` → ``succeeded`` / ``failed`` / ``cancelled``; a queued or
running task may be ``paused`` (a running robot stops; resumed, the task is queued again and
goes on from the leg it was on).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ...bus.services import GoalHandle
from ...robot.model import Pose2D
from ..ground import messages as m

GOTO, SEQUENCE, PATROL, CHARGE = "goto", "sequence", "patrol", "charge"
KINDS = (GOTO, SEQUENCE, PATROL, CHARGE)
QUEUED, RUNNING, PAUSED = "queued", "running", "paused"
SUCCEEDED, FAILED, CANCELLED = "succeeded", "failed", "cancelled"
OPEN = (QUEUED, RUNNING, PAUSED)
MAX_STOPS = 50
"""POIs in one sequence or patrol route."""
MAX_LAPS = 100
MAX_DWELL = 3600.0


class Refused(Exception):
    """A request that cannot be accepted; the text is the reply's message."""


@dataclass
class Stop:
    """One place a task goes to: a POI's name ("" for a pose), where, and the seconds it waits."""

    name: str
    pose: Pose2D
    dwell: float = 0.0


@dataclass
class Task:
    id: int
    kind: str
    stops: list[Stop]
    robot: str  # asked for ("" = whichever bids best)
    priority: int = 0
    laps: int = 1
    created: float = 0.0
    started: float = 0.0
    finished: float = 0.0
    assigned: str = ""  # running it, or that last ran it
    reserved: str = ""  # the robot whose bid won while it waits
    state: str = QUEUED
    message: str = "waiting for a robot"
    tried: list[str] = field(default_factory=list)
    leg: int = 0  # stops done so far (over every lap): a resumed task goes on from here
    goal: GoalHandle | None = None

    @property
    def open(self) -> bool:
        return self.state in OPEN

    @property
    def route(self) -> list[Stop]:
        """Every stop in order, each lap of a patrol included."""
        return self.stops * max(1, self.laps)

    def target(self) -> Pose2D:
        return self.stops[0].pose

    def msg(self) -> dict:
        first = self.stops[0]
        return {"id": self.id, "poi": first.name, "pose": m.pose(first.pose),
                "robot": self.robot, "assigned": self.assigned, "state": self.state,
                "message": self.message, "tried": list(self.tried), "kind": self.kind,
                "priority": self.priority, "pois": [s.name for s in self.stops],
                "dwell": [s.dwell for s in self.stops], "laps": self.laps,
                "created": self.created, "started": self.started, "finished": self.finished}

    def record(self) -> dict:
        """The task as the state folder keeps it (JSON)."""
        out = {k: v for k, v in self.msg().items() if k not in ("pose", "pois", "dwell")}
        out.update(reserved=self.reserved, leg=self.leg,
                   stops=[[s.name, s.pose.x, s.pose.y, s.pose.yaw, s.dwell] for s in self.stops])
        return out

    @classmethod
    def from_record(cls, r: dict) -> Task:
        """A task back from the state folder (``KeyError``/``ValueError``/``TypeError`` when
        it does not check out)."""
        stops = [Stop(str(n), Pose2D(float(x), float(y), float(yaw)), float(d))
                 for n, x, y, yaw, d in r["stops"]]
        if not stops or r["kind"] not in KINDS:
            raise ValueError("a task without stops or of an unknown kind")
        return cls(int(r["id"]), r["kind"], stops, str(r["robot"]), int(r["priority"]),
                   int(r["laps"]), float(r["created"]), float(r["started"]),
                   float(r["finished"]), str(r["assigned"]), str(r["reserved"]), str(r["state"]),
                   str(r["message"]), [str(t) for t in r["tried"]], int(r["leg"]))


def checked_pose(pose: Pose2D, what: str, limit: float) -> Pose2D:
    """A target's numbers: finite and within ``limit`` m of the origin (no site is larger; the
    planner then says whether it is on the map and reachable)."""
    if not all(math.isfinite(v) for v in (pose.x, pose.y, pose.yaw)):
        raise Refused(f"{what}: not a finite pose")
    if abs(pose.x) > limit or abs(pose.y) > limit:
        raise Refused(f"{what}: ({pose.x:g}, {pose.y:g}) is off the map (farther than "
                      f"{limit:g} m from its origin)")
    return pose

"""Driving one planned path through the mutex zones (see :mod:`.traffic` for the rule): the
path is cut at the spot before each run of zones; the robot drives to it, holds the run's zones
(waiting there if it must), and drives on to the next spot, letting each run go behind it."""

from __future__ import annotations

from collections.abc import Awaitable, Callable

import numpy as np

from .tasks import RUNNING, Task
from .traffic import Run, Traffic

Follow = Callable[[Task, str, dict, Callable[[dict], None] | None], Awaitable[None]]


async def cross(traffic: Traffic, task: Task, robot: str, path: dict, follow: Follow,
                changed: Callable[[], None]) -> None:
    """Follow ``path`` on ``robot`` holding each zone it passes (returns early when the task
    stops while the robot waits)."""
    points = path_points(path)
    runs = traffic.runs(points)
    if not runs:
        await follow(task, robot, path, None)
        return
    last = len(points) - 1
    at, behind = 0, None  # where the robot is on the path; the run it has just entered
    try:
        for ahead in [*runs, None]:
            low = behind.exit if behind is not None else 0
            end = traffic.spot(robot, points, max(at, low), ahead.entry) if ahead else last
            if end > at:
                await follow(task, robot, piece(path, at, end),
                             _past(traffic, task, robot, behind, points, at, end, changed))
            if behind is not None:
                traffic.passed(robot, behind.zones)
            at = end
            if ahead is None:
                break
            if not await _hold(traffic, task, robot, ahead, changed):
                return
            behind = ahead
    finally:
        traffic.spots.pop(robot, None)
        traffic.passed(robot)  # the motion ended: whatever it still holds ends once clear


async def _hold(traffic: Traffic, task: Task, robot: str, run: Run,
                changed: Callable[[], None]) -> bool:
    if task.state != RUNNING:
        return False

    def waiting(text: str) -> None:
        task.message = f"{robot} {text}"
        changed()

    got = await traffic.acquire(robot, run.zones, waiting)
    if got and task.state == RUNNING:
        task.message = f"{robot} crossing zone {', '.join(sorted(run.zones))}"
        changed()
    return got and task.state == RUNNING


def path_points(path: dict) -> np.ndarray:
    """A ``nav_msgs/Path``'s points, (N, 2)."""
    return np.array([(p["pose"]["position"]["x"], p["pose"]["position"]["y"])
                     for p in path["poses"]], dtype=np.float64).reshape(-1, 2)


def piece(path: dict, start: int, end: int) -> dict:
    return {"header": path["header"], "poses": path["poses"][start:end + 1]}


def _past(traffic: Traffic, task: Task, robot: str, run: Run | None, points: np.ndarray,
          start: int, end: int, changed: Callable[[], None]) -> Callable[[dict], None] | None:
    """A feedback handler marking ``run`` passed once the robot is beyond its exit point."""
    if run is None:
        return None
    steps = np.hypot(*np.diff(points[start:end + 1], axis=0).T)
    exit_left = float(steps[max(0, run.exit - start):].sum())  # path left at the exit
    told = False

    def on_feedback(feedback: dict) -> None:
        nonlocal told
        if float(feedback.get("distance_to_goal", np.inf)) <= exit_left + 1e-6:
            traffic.passed(robot, run.zones)
            if not told:
                told = True
                task.message = f"{robot} is past zone {', '.join(sorted(run.zones))}"
                changed()

    return on_feedback

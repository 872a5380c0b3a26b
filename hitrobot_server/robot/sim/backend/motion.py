"""The simulated robot's actions and velocity control; ``compute_path`` plans on its costmap
with the planner its moves use."""

from __future__ import annotations

from collections.abc import Sequence

from ...backend import MotionBackend
from ...model import ActionDirection, ActionInfo, MoveOptions, Point2D, Pose2D
from ...planning.search import check_poses, searched_path
from ..commands import Actions
from ..runner import RunnerPart


class SimMotion(RunnerPart, MotionBackend):
    @property
    def _actions(self) -> Actions:
        return self.runner.simulator.actions

    async def move_to(self, targets: Sequence[Point2D], options: MoveOptions | None = None,
                      yaw: float = 0.0) -> ActionInfo:
        return self.runner.call(self._actions.move_to, targets, options, yaw)

    async def compute_path(self, start: Pose2D | None, goal: Pose2D,
                           options: MoveOptions | None = None) -> list[Point2D]:
        """A* on the current planning costmap with ``move_to``'s options, run in slices of
        :data:`~...planning.planner.PLAN_SLICE` expansions so a long search never stalls the
        loop."""
        options = options or MoveOptions()
        check_poses(start, goal)
        sim = self.runner.call(lambda: self.runner.simulator)
        origin = sim.pose if start is None else start
        return await searched_path(sim.costmap(), origin, goal, options, self.runner.alive)

    async def move_by_direction(self, direction: ActionDirection,
                                options: MoveOptions | None = None,
                                duration: float = 0.5) -> ActionInfo:
        return self.runner.call(self._actions.move_by_direction, direction, options, duration)

    async def move_by_theta(self, theta: float, options: MoveOptions | None = None,
                            duration: float = 0.5) -> ActionInfo:
        return self.runner.call(self._actions.move_by_theta, theta, options, duration)

    async def rotate_to(self, yaw: float, options: MoveOptions | None = None) -> ActionInfo:
        return self.runner.call(self._actions.rotate_to, yaw, options)

    async def rotate(self, angle: float, options: MoveOptions | None = None) -> ActionInfo:
        return self.runner.call(self._actions.rotate, angle, options)

    async def go_home(self, options: MoveOptions | None = None) -> ActionInfo:
        return self.runner.call(self._actions.go_home, options)

    async def cancel_action(self) -> ActionInfo | None:
        return self.runner.call(self._actions.cancel_action)

    async def get_current_action(self) -> ActionInfo | None:
        return self.runner.call(self._actions.current_action)

    async def get_action(self, action_id: int) -> ActionInfo | None:
        return self.runner.call(self._actions.action, action_id)

    async def get_remaining_path(self) -> list[Point2D]:
        return self.runner.call(self._actions.remaining_path)

    async def get_remaining_milestones(self) -> list[Point2D]:
        return self.runner.call(self._actions.remaining_milestones)

    async def set_velocity(self, linear: float, angular: float) -> None:
        self.runner.call(self._actions.set_velocity, linear, angular)

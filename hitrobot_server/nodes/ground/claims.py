"""Who took the robot over: a velocity command (``/cmd_vel``) supersedes whatever action runs
on the robot, on a real Slamware robot as in the simulator, and the robot only says
"superseded". The node that carries the command out notes who sent it against the action it
ended; the node whose goal that was names them when it reports the end."""

from __future__ import annotations

from collections import OrderedDict

from ...bus.topics import Origin

KEPT = 32
"""Takeovers remembered (by the superseded action's id): enough for any watcher to ask."""


def who(origin: Origin | None, what: str) -> str:
    """``what`` from a client, named as an operator can find it (its node and address)."""
    if origin is None:
        return f"{what} from this server"
    peer = f" ({origin.peer})" if origin.peer else ""
    return f"{what} from {origin.node}{peer}"


class MotionClaims:
    """One robot's takeovers: the id of an action a request ended → who sent that request."""

    def __init__(self) -> None:
        self._by_action: OrderedDict[int, str] = OrderedDict()

    def took_over(self, action_id: int, by: str) -> None:
        """``by`` (see :func:`who`) started a motion that supersedes action ``action_id``."""
        self._by_action[action_id] = by
        self._by_action.move_to_end(action_id)
        while len(self._by_action) > KEPT:
            self._by_action.popitem(last=False)

    def taken_by(self, action_id: int | None) -> str | None:
        """Who superseded action ``action_id``, if a request noted it."""
        return None if action_id is None else self._by_action.get(action_id)

    def why_ended(self, action_id: int | None, reason: str) -> str:
        """The robot's ``reason`` an action ended, or who took the robot over from it."""
        by = self.taken_by(action_id)
        return f"taken over by {by}" if by else reason

"""How the Slamware node carries a validated request out, and what its publisher hears.

A motion request starts an action that may fail much later (no path, stuck, ...); the real
node says nothing then, we watch the action and tell the requester why.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

from ...bus.requests import Reply
from ...bus.topics import Message
from ...robot.backend import MotionBackend
from ...robot.model import ActionInfo, ActionResult
from ...robot.motion import follow
from ..base import RobotNode
from ..ground.requests import answer, require_robot

Request = tuple[str, str, Callable[[Message], None]]
"""(topic, type, handler) of one request topic."""


class Runner:
    """Runs requests in the node's background; robot failures go back to the publisher."""

    def __init__(self, node: RobotNode, motion: MotionBackend):
        self.node, self.motion = node, motion

    def run(self, message: Message, what: str, call: Callable[[], Awaitable[Any]]) -> None:
        async def carry_out() -> str | None:
            result = await call()
            if isinstance(result, ActionInfo):
                await self._watch_action(message.reply, what, result)
            elif result is False:
                message.reply.fail(f"{what}: the robot refused the request")
            elif isinstance(result, str):
                return result  # done: answered as ok with this text
            return None

        require_robot(self.node.link, what)
        self.node.spawn(answer(message.reply, what, carry_out()))

    async def _watch_action(self, reply: Reply, what: str, action: ActionInfo) -> None:
        final = await follow(self.motion, action)
        if final is None:  # replaced by a newer action, or forgotten by the robot
            return
        action = final
        if action.result == ActionResult.SUCCESS:
            reply.ok(f"{what}: done")
        elif action.result == ActionResult.ABORTED:  # cancelled or superseded: not an error
            reply.info(f"{what}: {action.reason or 'cancelled'}")
        else:
            why = action.reason or action.result.name.lower()
            reply.fail(f"{what} failed: {why}")

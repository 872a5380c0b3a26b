"""Robot motion as the nodes use it: start an action, follow it, stop it if it is still ours.

Every node that drives the robot (the Slamware topics, ``/navigation``, patrols, graph
navigation, ``/move_base``, the nav2 and intelligent-navigation actions) goes through these
helpers, so they all look at a running action at the same pace (:data:`POLL_PERIOD`) and never
cancel an action that another command has started since.

The locomotion gate: the motion the nodes hold is a
:class:`~hitrobot_server.robot.locomotion.GatedMotion`; its motion methods refuse with
:class:`BackendError` while the robot sits, stands up or is claimed by another control source
(:meth:`~hitrobot_server.robot.locomotion.Locomotion.check_motion`). Starting a motion
here therefore either returns an action or raises that refusal, which the helpers turn into the
caller's reply; stopping (:func:`cancel_if_current`) is never gated.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import TypeVar

from .backend import BackendError, MotionBackend, NotConnectedError
from .model import ActionInfo, ActionResult, MoveOptionFlag

log = logging.getLogger(__name__)

POLL_PERIOD = 0.1
"""Seconds between looks at a running robot action (the one poll policy of every node)."""

GOAL_FLAGS = MoveOptionFlag.MILESTONE | MoveOptionFlag.PRECISE | MoveOptionFlag.WITH_YAW
"""How a navigation goal (``move_base_simple/goal``, ``/move_base``) is driven: precisely,
through its milestone, turning to the goal's heading at the end."""

T = TypeVar("T")

SUCCEEDED, FAILED, PREEMPTED, CANCELED, GONE = (
    "succeeded", "failed", "preempted", "canceled", "gone")


@dataclass(frozen=True)
class MotionEnd:
    """How a watched motion ended: ``kind`` is succeeded, failed (refused, unreachable, the
    robot disconnected or forgot the action), preempted (stopped on the robot, not by us),
    canceled (by the caller's cancel event; the robot was stopped) or gone (the caller stopped
    wanting it, see :func:`watch`)."""

    kind: str
    reason: str = ""


async def follow(backend: MotionBackend, action: ActionInfo,
                 period: float = POLL_PERIOD) -> ActionInfo | None:
    """Wait for the robot's ``action`` to end: its final state, or ``None`` when the robot no
    longer knows it (replaced by a newer one). Robot errors propagate."""
    while not action.done:
        await asyncio.sleep(period)
        current = await backend.get_action(action.action_id)
        if current is None:
            return None
        action = current
    return action


async def cancel_if_current(backend: MotionBackend, action_id: int | None,
                            who: str = "") -> None:
    """Cancel the robot's current action if it is still ``action_id`` (never someone else's);
    a robot error is logged, not raised."""
    if action_id is None:
        return
    try:
        current = await backend.get_current_action()
        if current is not None and current.action_id == action_id:
            await backend.cancel_action()
    except BackendError as exc:
        log.warning("%sstopping robot action %s: %s", who, action_id, exc)


def end_of(action: ActionInfo) -> MotionEnd:
    """The :class:`MotionEnd` of a finished robot action."""
    if action.result == ActionResult.SUCCESS:
        return MotionEnd(SUCCEEDED)
    if action.result == ActionResult.FAILED:
        return MotionEnd(FAILED, action.reason or "the robot could not reach the goal")
    return MotionEnd(PREEMPTED, f"stopped on the robot: {action.reason or 'aborted'}")


async def watch(
    backend: MotionBackend,
    action_id: int,
    sample: Callable[[], Awaitable[T]],
    on_poll: Callable[[ActionInfo, T], None],
    *,
    cancelled: asyncio.Event | None = None,
    gone: Callable[[], bool] = lambda: False,
    period: float = POLL_PERIOD,
    who: str = "",
) -> MotionEnd:
    """Look at robot action ``action_id`` every ``period`` s until it ends.

    Each look fetches the action and ``sample()`` (the pose or odometry the caller reports);
    ``on_poll`` sees them while the action runs. A robot error other than a disconnection is
    transient (look again). With ``cancelled``, setting the event stops the robot's action if
    it is still ours and ends as canceled, and so does cancelling the watching task (which is
    then re-raised). ``gone()`` true (checked before and after each look) ends as gone without
    touching the robot: the caller has already moved on."""
    waiter = asyncio.ensure_future(cancelled.wait()) if cancelled is not None else None
    try:
        while True:
            if waiter is not None:
                await asyncio.wait({waiter}, timeout=period)
            else:
                await asyncio.sleep(period)
            if cancelled is not None and cancelled.is_set():
                await cancel_if_current(backend, action_id, who)
                return MotionEnd(CANCELED, "canceled")
            if gone():
                return MotionEnd(GONE)
            try:
                action = await backend.get_action(action_id)
                sampled = await sample()
            except NotConnectedError:
                return MotionEnd(FAILED, "the robot disconnected")
            except BackendError as exc:  # transient: look again on the next poll
                log.warning("%spolling robot action %s: %s", who, action_id, exc)
                continue
            if gone():
                return MotionEnd(GONE)
            if action is None:
                return MotionEnd(FAILED, "the robot no longer knows the goal's action")
            if not action.done:
                on_poll(action, sampled)
                continue
            return end_of(action)
    except asyncio.CancelledError:
        if cancelled is not None:  # the caller's task went away: leave the robot still
            with contextlib.suppress(Exception):
                await asyncio.shield(cancel_if_current(backend, action_id, who))
        raise
    finally:
        if waiter is not None:
            waiter.cancel()


async def drive(
    backend: MotionBackend,
    cancelled: asyncio.Event,
    start: Callable[[], Awaitable[ActionInfo]],
    sample: Callable[[], Awaitable[T]],
    on_poll: Callable[[ActionInfo, T], None],
    period: float = POLL_PERIOD,
) -> MotionEnd:
    """Start a robot motion with ``start`` (through the locomotion gate) and :func:`watch` it
    until it ends or ``cancelled`` is set (the robot is then stopped)."""
    if cancelled.is_set():
        return MotionEnd(CANCELED, "canceled before the robot moved")
    try:
        info = await start()
    except NotConnectedError:
        return MotionEnd(FAILED, "the robot is not connected")
    except BackendError as exc:
        return MotionEnd(FAILED, f"the robot refused the goal: {exc}")
    return await watch(backend, info.action_id, sample, on_poll, cancelled=cancelled,
                       period=period)

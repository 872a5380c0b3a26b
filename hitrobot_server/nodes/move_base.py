"""``/move_base``: a ROS 1 actionlib server (``move_base_msgs/MoveBaseAction``) over plain topics.

roslibjs's and roslibpy's ``ActionClient`` (and nav2d's Navigator) speak actionlib as five
topics: they publish ``/move_base/goal`` and ``/move_base/cancel`` and listen to
``/move_base/status``, ``/move_base/feedback`` and ``/move_base/result``. This node is the
server side, with the semantics of ``move_base``'s SimpleActionServer:

* one goal runs at a time; a new goal preempts the running one (old → PREEMPTED, or RECALLED
  if it had not started yet);
* an invalid goal (NaN, a frame other than the map) is REJECTED with the reason, and leaves
  the running goal alone; an all-zero quaternion is accepted as yaw 0; so is a goal on an
  obstacle of ``/map`` or nearer one than the robot's clearance (``ground/placement.py``:
  "goal (3.20, 1.10) is on an obstacle", the publisher told that one line), before the robot
  moves;
* the goal is the robot's ``move_to`` (precise, with yaw); its action is polled until done:
  success → SUCCEEDED, failure (no path, blocked, ...) → ABORTED with the robot's reason, an
  action cancelled or replaced on the robot by someone else → PREEMPTED with the robot's
  reason, the robot disconnecting → ABORTED;
* a cancel (``actionlib_msgs/GoalID``; empty id and zero stamp = every goal, a stamp = every
  goal stamped at or before it) → PREEMPTING then PREEMPTED once the robot was told to stop,
  or RECALLED for a goal that had not started;
* ``/move_base/status`` is published every 100 ms even when idle (roslibpy's ActionClient
  blocks until it sees one) and on every transition; finished goals stay in its list for
  5 s, as actionlib's ``status_list_timeout``; feedback carries the robot's pose;
* a simple goal (``geometry_msgs/PoseStamped`` on ``move_base_simple/goal``, when the assembly
  hands the node that topic) is wrapped as an action goal, as ROS's ``move_base`` does: its id
  generated, it runs, is listed, gets feedback and a result, and preempts, exactly as a goal
  received on ``/move_base/goal`` (a refused field is named by its path in the PoseStamped);
* the same server is a bus action ``/move_base`` (``move_base_msgs/MoveBase``, the
  ``send_action_goal`` op and ``/move_base/_action/*``), over the one goal table: every goal,
  whichever way it came, is a bus goal too, so it is listed, fed back and cancelled both ways
  (a goal sent with the op has its ROS 2 goal id, in hex, as its actionlib id).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field

from ..bus.core import Bus
from ..bus.services import (
    STATUS_ABORTED,
    STATUS_CANCELED,
    STATUS_SUCCEEDED,
    GoalHandle,
    GoalOutcome,
)
from ..bus.topics import Message, RequestRejected
from ..robot import motion
from ..robot.backend import (
    BackendError,
    Link,
    LocalizationBackend,
    MotionBackend,
)
from ..robot.model import MoveOptions, Point2D, Pose2D
from ..robot.motion import GOAL_FLAGS, cancel_if_current, watch
from .base import RobotNode
from .ground import messages as m
from .ground.claims import MotionClaims
from .ground.messages import map_frames, pose2d_of
from .ground.pacing import Pace
from .ground.placement import target_problem
from .ground.requests import require_robot, robot_error

log = logging.getLogger(__name__)

PENDING, ACTIVE, PREEMPTED, SUCCEEDED, ABORTED, REJECTED = 0, 1, 2, 3, 4, 5
PREEMPTING, RECALLING, RECALLED, LOST = 6, 7, 8, 9
TERMINAL = frozenset({PREEMPTED, SUCCEEDED, ABORTED, REJECTED, RECALLED, LOST})

STATUS_PERIOD = 0.1
"""Seconds between ``status`` messages (actionlib's default is 5 Hz; we send 10)."""
STATUS_LIST_TIMEOUT = 5.0
"""Seconds a finished goal stays in the status list (actionlib's ``status_list_timeout``)."""
_OUTCOMES = {SUCCEEDED: STATUS_SUCCEEDED, PREEMPTED: STATUS_CANCELED, RECALLED: STATUS_CANCELED}
"""actionlib's terminal states as action_msgs' (every other one is ABORTED)."""
NEW_GOAL_TEXT = "This goal was canceled because another goal was received by the action server"
CANCEL_TEXT = "cancelled by a cancel request"


@dataclass(eq=False)
class Goal:
    """One goal the server knows, from acceptance until it drops out of the status list."""

    goal_id: dict
    target: Pose2D | None = None
    status: int = PENDING
    text: str = ""
    action_id: int | None = None
    finished: float | None = None
    message: Message | None = field(default=None, repr=False)
    task: asyncio.Task | None = field(default=None, repr=False)
    handle: GoalHandle | None = field(default=None, repr=False)  # the bus action's goal
    ended: asyncio.Event = field(default_factory=asyncio.Event, repr=False)

    @property
    def id(self) -> str:
        return self.goal_id["id"]

    @property
    def stamp(self) -> tuple[int, int]:
        s = self.goal_id["stamp"]
        return s["secs"], s["nsecs"]

    @property
    def status_msg(self) -> dict:
        """Its ``actionlib_msgs/GoalStatus``."""
        return {"goal_id": self.goal_id, "status": self.status, "text": self.text}

    @property
    def done(self) -> bool:
        return self.status in TERMINAL


def filled_id(sent_id: dict, server: str, ids: Iterator[int], now: float) -> dict:
    """A goal id as actionlib fills one in: an empty id generated (GoalIDGenerator's
    name-count-stamp, its count the next of ``ids``), a zero stamp made now."""
    goal_id = {"stamp": dict(sent_id["stamp"]), "id": sent_id["id"]}
    if not goal_id["id"]:
        goal_id["id"] = f"{server}-{next(ids)}-{now:.6f}"
    if goal_id["stamp"]["secs"] == 0 and goal_id["stamp"]["nsecs"] == 0:
        goal_id["stamp"] = m.stamp(now)
    return goal_id


def cancelled_by(cancel: dict, goals: Iterable[Goal]) -> list[Goal]:
    """The unfinished goals an ``actionlib_msgs/GoalID`` cancels: empty id and zero stamp,
    every one; an id, that one; a stamp, every one stamped at or before it."""
    cancel_id, stamp = cancel["id"], (cancel["stamp"]["secs"], cancel["stamp"]["nsecs"])
    everything = not cancel_id and stamp == (0, 0)
    return [g for g in goals if not g.done and (
        everything or g.id == cancel_id or (stamp != (0, 0) and g.stamp <= stamp))]


Accept = Callable[[Message | None, dict, dict, str, GoalHandle | None], Goal | None]


class BusGoals:
    """The bus action ``/move_base`` over the actionlib goal table: a goal of the bus action
    (``send_action_goal``, ``/move_base/_action/send_goal``) is taken as an actionlib goal
    (``accept``), and a goal from a topic is made a bus goal too (``adopt``), so each is
    listed and cancelled both ways."""

    def __init__(self, bus: Bus, server: str, accept: Accept,
                 cancel: Callable[[Goal, str], None]):
        self.bus, self.server, self.accept, self.cancel = bus, server, accept, cancel
        self._adopting: dict[str, Goal] = {}  # goals that came on topics, by bus goal id

    def adopt(self, goal: Goal, tp: dict) -> None:
        """Start a bus goal for a goal that came on a topic; its handler, run once the loop
        turns, finds it here rather than taking another."""
        if self.bus.action(self.server) is None:  # replaced by a client's provider
            return
        handle, _task = self.bus.start_goal(self.server, {"target_pose": tp})
        goal.handle = handle
        self._adopting[handle.goal_id] = goal

    async def run(self, handle: GoalHandle) -> GoalOutcome:
        """Run one bus goal to its outcome (its actionlib id: the ROS 2 goal id in hex)."""
        goal = self._adopting.pop(handle.goal_id, None)
        if goal is None:
            unset = {"stamp": {"secs": 0, "nsecs": 0}, "id": handle.uuid.hex()}
            goal = self.accept(None, unset, handle.goal["target_pose"], "target_pose.", handle)
            if goal is None:
                return GoalOutcome(STATUS_ABORTED, f"goal id '{unset['id']}' is already known",
                                   False)
        handle.on_cancel.append(lambda: self.cancel(goal, CANCEL_TEXT))
        if handle.cancelled.is_set():
            self.cancel(goal, CANCEL_TEXT)
        await goal.ended.wait()
        status = _OUTCOMES.get(goal.status, STATUS_ABORTED)
        if status == STATUS_SUCCEEDED:
            return GoalOutcome(status, {}, True)
        return GoalOutcome(status, goal.text or f"goal ended with actionlib status {goal.status}",
                           False)


class MoveBaseNode(RobotNode):
    """The actionlib server for ``/move_base`` (the server name is configurable)."""

    GLOBAL_NAMES = ("/move_base",)

    def __init__(self, bus: Bus, link: Link, motion: MotionBackend,
                 localization: LocalizationBackend, map_frame: str = "/map",
                 server: str = "/move_base", simple_goal: str | None = None,
                 claims: MotionClaims | None = None):
        super().__init__(bus, server, link)
        self.claims = claims or MotionClaims()  # who took the robot over from a goal
        self.motion, self.localization, self.server = motion, localization, server
        self.map_frame, self.frames = map_frame, map_frames(map_frame)
        self.goals: dict[str, Goal] = {}
        self.current: Goal | None = None
        self._lock = asyncio.Lock()  # one robot command at a time, in arrival order
        self._ids = itertools.count(1)
        self._seqs: dict[str, itertools.count] = {}
        pkg = "move_base_msgs/MoveBaseAction"
        self.advertise(f"{server}/status", "actionlib_msgs/GoalStatusArray")
        self.advertise(f"{server}/feedback", f"{pkg}Feedback")
        self.advertise(f"{server}/result", f"{pkg}Result")
        self.subscribe(f"{server}/goal", f"{pkg}Goal", self._on_goal)
        self.subscribe(f"{server}/cancel", "actionlib_msgs/GoalID", self._on_cancel)
        if simple_goal:  # ROS move_base's move_base_simple/goal
            self.subscribe(simple_goal, "geometry_msgs/PoseStamped", self._on_simple_goal)
        self.bus_goals = BusGoals(bus, server, self._accept, self.cancel_goal)
        self.action(server, "move_base_msgs/action/MoveBase", self.bus_goals.run)

    async def start(self) -> None:
        self.every(STATUS_PERIOD, self._tick, needs_robot=False,  # 10 Hz while it is read
                   pace=Pace(self.bus.demand, (f"{self.server}/status",), STATUS_PERIOD))

    async def _tick(self) -> None:
        now = time.monotonic()
        for gid, goal in list(self.goals.items()):
            if goal.finished is not None and now - goal.finished > STATUS_LIST_TIMEOUT:
                del self.goals[gid]
        self._publish_status()

    # ------------------------------------------------------------------ publishing
    def _header(self, topic: str, frame: str = "") -> dict:
        """A header numbered per topic, as a ROS publisher numbers its messages."""
        seq = self._seqs.setdefault(topic, itertools.count(1))
        return m.header(frame, self.bus.clock(), next(seq))

    def _publish_status(self) -> None:
        self.publish(f"{self.server}/status", {
            "header": self._header("status"),
            "status_list": [g.status_msg for g in self.goals.values()],
        })

    def _publish_feedback(self, goal: Goal, pose: Pose2D) -> None:
        feedback = {"base_position": {"header": self._header("pose", self.map_frame),
                                      "pose": m.pose(pose)}}
        self.publish(f"{self.server}/feedback", {
            "header": self._header("feedback"),
            "status": goal.status_msg,
            "feedback": feedback,
        })
        if goal.handle is not None:
            goal.handle.feedback(feedback)

    def _finish(self, goal: Goal, status: int, text: str = "", said: str = "") -> None:
        """Move ``goal`` to a terminal state: status first, then the result (roslibpy's Goal
        only counts as finished once it has both). ``said``: what its publisher is told, when
        the text says it all (a refused place: one message, no goal id)."""
        if goal.done:
            return
        goal.status, goal.text, goal.finished = status, text, time.monotonic()
        goal.ended.set()
        if self.current is goal:
            self.current = None
        self._publish_status()
        self.publish(f"{self.server}/result", {
            "header": self._header("result"), "status": goal.status_msg, "result": {}})
        if goal.message is not None and status in (ABORTED, REJECTED):
            goal.message.reply.fail(said or f"goal '{goal.id}' "
                                    f"{'aborted' if status == ABORTED else 'rejected'}: {text}")

    # ------------------------------------------------------------------ goals
    def _on_goal(self, message: Message) -> None:
        msg = message.msg
        self._accept(message, msg["goal_id"], msg["goal"]["target_pose"], "goal.target_pose.")

    def _on_simple_goal(self, message: Message) -> None:
        """A PoseStamped, run as an action goal without an id (generated) or stamp (now)."""
        unset = {"stamp": {"secs": 0, "nsecs": 0}, "id": ""}
        self._accept(message, unset, message.msg, "")

    def _accept(self, message: Message | None, sent_id: dict, tp: dict, path: str,
                handle: GoalHandle | None = None) -> Goal | None:
        """Take a goal (``tp``: its target, a PoseStamped at ``path`` in the message), as
        the bus goal ``handle`` (a goal from a topic is made one here)."""
        goal_id = filled_id(sent_id, self.server, self._ids, self.bus.clock())
        if goal_id["id"] in self.goals:
            if message is not None:
                message.reply.warn(f"goal id '{goal_id['id']}' is already known; goal ignored")
            return None
        goal = Goal(goal_id, message=message, handle=handle)
        self.goals[goal.id] = goal
        if handle is None:
            self.bus_goals.adopt(goal, tp)
        try:
            frame = tp["header"]["frame_id"]
            if frame not in self.frames:
                raise RequestRejected(f"field '{path}header.frame_id': '{frame}' is "
                                      "not the map frame")
            goal.target = pose2d_of(tp["pose"], f"{path}pose")
            require_robot(self.link, "")
        except RequestRejected as exc:
            self._finish(goal, REJECTED, str(exc))  # tells the publisher too
            return goal
        if problem := target_problem(self.bus, "goal", goal.target.x, goal.target.y):
            self._finish(goal, REJECTED, problem, said=problem)  # the robot does not move
            return goal
        previous, self.current = self.current, goal
        self._publish_status()
        if previous is not None and not previous.done:
            self._stop_watching(previous)
            self._finish(previous, RECALLED if previous.status == PENDING else PREEMPTED,
                         NEW_GOAL_TEXT)
        goal.task = self.spawn(self._execute(goal))
        return goal

    async def _execute(self, goal: Goal) -> None:
        assert goal.target is not None
        target = goal.target
        async with self._lock:
            if goal.done:  # recalled or replaced while waiting for the robot
                return
            try:
                info = await self.motion.move_to(
                    [Point2D(target.x, target.y)], MoveOptions(flags=GOAL_FLAGS), target.yaw)
            except BackendError as exc:
                self._finish(goal, ABORTED, robot_error(exc, "the robot refused the goal"))
                return
            goal.action_id = info.action_id
            if goal.done:  # cancelled while the robot was being asked: undo
                if goal.status == RECALLED and self.current is None:
                    await cancel_if_current(self.motion, info.action_id, "move_base: ")
                return
            goal.status = ACTIVE
            self._publish_status()
        await self._watch(goal)

    async def _watch(self, goal: Goal) -> None:
        if goal.done or goal.action_id is None:
            return
        end = await watch(self.motion, goal.action_id, self.localization.get_pose,
                          lambda _action, pose: self._publish_feedback(goal, pose),
                          gone=lambda: goal.done or goal.status != ACTIVE, who="move_base: ")
        if end.kind == motion.SUCCEEDED:
            self._finish(goal, SUCCEEDED, "")
        elif end.kind == motion.FAILED:
            self._finish(goal, ABORTED, end.reason)
        elif end.kind == motion.PREEMPTED:  # cancelled or replaced on the robot, not through us
            self._finish(goal, PREEMPTED, self.claims.why_ended(goal.action_id, end.reason))

    def _stop_watching(self, goal: Goal) -> None:
        task = goal.task
        if task is not None and task is not asyncio.current_task():
            task.cancel()

    # ------------------------------------------------------------------ cancel
    def _on_cancel(self, message: Message) -> None:
        cancel_id = message.msg["id"]
        targets = cancelled_by(message.msg, self.goals.values())
        if not targets and cancel_id and cancel_id not in self.goals:
            message.reply.warn(f"no goal with id '{cancel_id}'")
        for goal in targets:
            self.cancel_goal(goal, CANCEL_TEXT)

    def cancel_all(self, text: str = CANCEL_TEXT) -> int:
        """Cancel every unfinished goal (``/cmd_string cancel``); how many there were."""
        targets = [g for g in self.goals.values() if not g.done]
        for goal in targets:
            self.cancel_goal(goal, text)
        return len(targets)

    def cancel_goal(self, goal: Goal, text: str) -> None:
        if goal.done or goal.status in (PREEMPTING, RECALLING):
            return
        if goal.status == PENDING:
            self._finish(goal, RECALLED, text)
            return
        goal.status = PREEMPTING
        if self.current is goal:
            self.current = None
        self._stop_watching(goal)
        self._publish_status()
        self.spawn(self._preempt(goal, text))

    async def _preempt(self, goal: Goal, text: str) -> None:
        async with self._lock:
            await cancel_if_current(self.motion, goal.action_id, "move_base: ")
        self._finish(goal, PREEMPTED, text)

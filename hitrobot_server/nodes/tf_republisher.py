"""``tf2_web_republisher``: TF for web clients, the way roslibjs' and roslibpy's TF clients ask.

A browser cannot run a tf2 buffer over a rosbridge link cheaply, so these clients ask a
republisher for "frames A, B in frame F, at most R times a second, only when they moved more
than T metres or turned more than θ radians". We keep the tree from ``/tf`` and ``/tf_static``
(:mod:`hitrobot_server.tf_buffer`) and answer all three forms the clients use:

* ROS 1 actionlib over topics, ``/tf2_web_republisher/{goal,cancel,feedback,status,result}``
  (``tf2_web_republisher/TFSubscriptionAction``): roslibjs ``TFClient``;
* the ROS 2 action ``/tf2_web_republisher`` (``tf2_web_republisher_interfaces/TFSubscription``):
  roslibjs 2.x ``ROS2TFClient``; the transforms come as feedback until the goal is cancelled;
* the service ``/republish_tfs`` (``tf2_web_republisher/RepublishTFs``): roslibpy ``TFClient``
  and roslibjs with ``groovyCompatibility`` off; the reply names a new ``/tf_repub_N`` topic
  (``TFArray``) that is dropped once it had no subscriber for the request's ``timeout``.
"""

from __future__ import annotations

import asyncio
import itertools
import math
from collections.abc import Awaitable, Callable
from dataclasses import dataclass

from ..bus.clock import ros_time
from ..bus.core import Bus
from ..bus.errors import ServiceError
from ..bus.services import STATUS_ABORTED, STATUS_CANCELED, GoalHandle, GoalOutcome
from ..bus.topics import Message, RequestRejected
from ..tf_buffer import TFBuffer, Transform, frame_name
from .base import RobotNode
from .ground.names import TF, TF_STATIC
from .ground.pacing import Pace

NODE_NAME = "/tf2_web_republisher"
SERVICE = "/republish_tfs"
MAX_RATE = 100.0
"""Highest rate served (Hz); a client asking for more gets this."""
MIN_TOPIC_TIMEOUT = 1.0
"""Seconds a ``/republish_tfs`` topic waits for its first subscriber at least."""
MAX_SUBSCRIPTIONS = 256
"""Concurrent subscriptions (all forms together); more are refused."""
STATUS_PERIOD = 0.2  # actionlib servers publish their status at 5 Hz

# actionlib_msgs/GoalStatus codes
AL_ACTIVE, AL_PREEMPTED, AL_REJECTED = 1, 2, 5


class Subscription:
    """One client's request and what it was last sent, frame by frame."""

    def __init__(self, goal: dict):
        sources = [frame_name(f) for f in goal["source_frames"]]
        if not sources or not all(sources):
            raise ValueError("field 'source_frames' must list at least one frame name")
        target = frame_name(goal["target_frame"])
        if not target:
            raise ValueError("field 'target_frame' must name a frame")
        rate, angular, trans = goal["rate"], goal["angular_thres"], goal["trans_thres"]
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"field 'rate' must be a positive number of Hz, got {rate}")
        for name, value in (("angular_thres", angular), ("trans_thres", trans)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"field '{name}' must be a number ≥ 0, got {value}")
        self.sources = list(dict.fromkeys(sources))
        self.target = target
        self.period = 1.0 / min(float(rate), MAX_RATE)
        self.angular = float(angular)
        self.trans = float(trans)
        self._sent: dict[str, Transform] = {}

    def changed(self, buffer: TFBuffer, now: float) -> list[dict]:
        """The frames that moved past a threshold since last sent (all of them the first time),
        as ``geometry_msgs/TransformStamped``; frames not connected to the target are left
        out until they are."""
        out = []
        for source in self.sources:
            found = buffer.lookup(self.target, source)
            if found is None:
                continue
            last = self._sent.get(source)
            if last is not None and (found.distance_to(last) <= self.trans
                                     and found.angle_to(last) <= self.angular):
                continue
            self._sent[source] = found
            (x, y, z), (qx, qy, qz, qw) = found.translation, found.rotation
            out.append({
                "header": {"seq": 0, "stamp": ros_time(found.stamp or now),
                           "frame_id": self.target},
                "child_frame_id": source,
                "transform": {"translation": {"x": x, "y": y, "z": z},
                              "rotation": {"x": qx, "y": qy, "z": qz, "w": qw}},
            })
        return out


@dataclass
class _Ros1Goal:
    goal_id: dict
    task: asyncio.Task


class TFRepublisherNode(RobotNode):
    """Serves TF subscriptions from the bus's ``/tf`` tree; runs with or without a robot."""

    GLOBAL_NAMES = (NODE_NAME, SERVICE, TF, TF_STATIC)

    def __init__(self, bus: Bus):
        super().__init__(bus, NODE_NAME, None)
        self.buffer = TFBuffer()
        self._ros1: dict[str, _Ros1Goal] = {}
        self._active = 0
        self._topic_ids = itertools.count(1)
        self._goal_ids = itertools.count(1)
        for topic in (TF, TF_STATIC):  # kept in the buffer; /tf wanted while one streams
            self.subscribe(topic, "tf2_msgs/TFMessage", self._on_tf, passive=True)
        action = "tf2_web_republisher/TFSubscriptionAction"
        self.advertise(f"{NODE_NAME}/feedback", f"{action}Feedback")
        self.advertise(f"{NODE_NAME}/result", f"{action}Result")
        self.advertise(f"{NODE_NAME}/status", "actionlib_msgs/GoalStatusArray")
        self.subscribe(f"{NODE_NAME}/goal", f"{action}Goal", self._on_goal)
        self.subscribe(f"{NODE_NAME}/cancel", "actionlib_msgs/GoalID", self._on_cancel)
        self.service(SERVICE, "tf2_web_republisher/RepublishTFs", self._republish)
        self.action(NODE_NAME, "tf2_web_republisher_interfaces/TFSubscription", self._ros2_goal)

    async def start(self) -> None:
        self.every(STATUS_PERIOD, self._publish_status, needs_robot=False,  # 5 Hz when read
                   pace=Pace(self.bus.demand, (f"{NODE_NAME}/status",), STATUS_PERIOD))

    def _on_tf(self, message: Message) -> None:
        for stamped in message.msg["transforms"]:
            self.buffer.add(stamped)

    def _subscription(self, goal: dict) -> Subscription:
        if self._active >= MAX_SUBSCRIPTIONS:
            raise ValueError(f"too many TF subscriptions (at most {MAX_SUBSCRIPTIONS})")
        return Subscription(goal)

    def _stream(self, sub: Subscription, send: Callable[[list[dict]], None]) -> asyncio.Task:
        """Hand ``sub``'s changed frames (maybe none) to ``send`` every period until the
        returned task is cancelled."""

        async def tick() -> None:
            send(sub.changed(self.buffer, self.bus.clock()))

        return self._counted(sub.period, tick)

    def _counted(self, period: float, tick: Callable[[], Awaitable[None]]) -> asyncio.Task:
        """A stream of TF to a client: ``/tf`` is wanted at its full rate while one runs."""
        self._active += 1
        if self._active == 1:
            self.bus.demand.want(TF, self)
        task = self.every(period, tick, needs_robot=False)
        task.add_done_callback(self._ended)
        return task

    def _ended(self, _task: asyncio.Task) -> None:
        self._active -= 1
        if self._active == 0:
            self.bus.demand.unwant(TF, self)

    # ------------------------------------------------------------------ ROS 1 actionlib
    def _header(self) -> dict:
        return {"seq": 0, "stamp": ros_time(self.bus.clock()), "frame_id": ""}

    def _on_goal(self, message: Message) -> None:
        msg = message.msg
        goal_id = {"stamp": dict(msg["goal_id"]["stamp"]), "id": msg["goal_id"]["id"]}
        now = self.bus.clock()
        if not goal_id["id"]:  # actionlib's own id scheme: name-count-stamp
            goal_id["id"] = f"{NODE_NAME}-{next(self._goal_ids)}-{now:.6f}"
        if goal_id["stamp"] == {"secs": 0, "nsecs": 0}:
            goal_id["stamp"] = ros_time(now)
        try:
            sub = self._subscription(msg["goal"])
        except ValueError as exc:
            self._publish_result(goal_id, AL_REJECTED, str(exc))
            raise RequestRejected(f"goal: {exc}") from None
        old = self._ros1.pop(goal_id["id"], None)
        if old is not None:
            old.task.cancel()

        sender = message.origin.node if message.origin is not None else None

        def send(transforms: list[dict]) -> None:
            if sender is not None and sender not in self.bus.nodes:
                self._end_ros1(goal_id["id"], "the client that sent the goal is gone")
            elif transforms:
                self.publish(f"{NODE_NAME}/feedback", {
                    "header": self._header(),
                    "status": {"goal_id": goal_id, "status": AL_ACTIVE, "text": ""},
                    "feedback": {"transforms": transforms},
                })

        self._ros1[goal_id["id"]] = _Ros1Goal(goal_id, self._stream(sub, send))
        self._publish_status_now()

    def _on_cancel(self, message: Message) -> None:
        """actionlib's rule: an id cancels that goal, a stamp every goal stamped at or before
        it, neither every goal."""
        cancel_id = message.msg["id"]
        stamp = message.msg["stamp"]
        before = (stamp["secs"], stamp["nsecs"])
        chosen = [g for g in self._ros1.values() if
                  g.goal_id["id"] == cancel_id
                  or (not cancel_id and before == (0, 0))
                  or (before != (0, 0) and (g.goal_id["stamp"]["secs"],
                                            g.goal_id["stamp"]["nsecs"]) <= before)]
        for goal in chosen:
            self._end_ros1(goal.goal_id["id"], "cancelled")

    def _end_ros1(self, goal_id: str, text: str) -> None:
        """Stop a goal (cancelled, or its client disconnected without cancelling: a reloaded
        page never does) and report it PREEMPTED."""
        goal = self._ros1.pop(goal_id, None)
        if goal is None:
            return
        goal.task.cancel()
        self._publish_result(goal.goal_id, AL_PREEMPTED, text)
        self._publish_status_now()

    def _publish_result(self, goal_id: dict, status: int, text: str) -> None:
        self.publish(f"{NODE_NAME}/result", {
            "header": self._header(),
            "status": {"goal_id": goal_id, "status": status, "text": text},
            "result": {},
        })

    async def _publish_status(self) -> None:
        topic = self.bus.topic(f"{NODE_NAME}/status")
        if topic is not None and topic.subscribers:
            self._publish_status_now()

    def _publish_status_now(self) -> None:
        self.publish(f"{NODE_NAME}/status", {"header": self._header(), "status_list": [
            {"goal_id": g.goal_id, "status": AL_ACTIVE, "text": ""}
            for g in self._ros1.values()]})

    # ------------------------------------------------------------------ ROS 2 action
    async def _ros2_goal(self, handle: GoalHandle) -> GoalOutcome:
        try:
            sub = self._subscription(handle.goal)
        except ValueError as exc:
            return GoalOutcome(STATUS_ABORTED, f"tf2_web_republisher: {exc}", False)
        task = self._stream(sub, lambda transforms: transforms and handle.feedback(
            {"transforms": transforms}))
        try:
            await handle.cancelled.wait()
        finally:
            task.cancel()
        return GoalOutcome(STATUS_CANCELED, {}, True)

    # ------------------------------------------------------------------ /republish_tfs
    async def _republish(self, request: dict) -> dict:
        try:
            sub = self._subscription(request)
        except ValueError as exc:
            raise ServiceError(f"republish_tfs: {exc}") from None
        timeout = request["timeout"]
        timeout = max(MIN_TOPIC_TIMEOUT, timeout["secs"] + timeout["nsecs"] * 1e-9)
        name = f"/tf_repub_{next(self._topic_ids)}"
        self.advertise(name, "tf2_web_republisher/TFArray")
        idle_since = [self.bus.clock()]
        task: list[asyncio.Task] = []

        async def tick() -> None:
            topic = self.bus.topic(name)
            now = self.bus.clock()
            if topic is not None and topic.subscribers:
                idle_since[0] = None
                transforms = sub.changed(self.buffer, now)
                if transforms:
                    self.publish(name, {"transforms": transforms})
            elif idle_since[0] is None:
                idle_since[0] = now
            elif now - idle_since[0] > timeout:
                self.bus.unadvertise(name, self)
                task[0].cancel()

        task.append(self._counted(sub.period, tick))
        return {"topic_name": name}

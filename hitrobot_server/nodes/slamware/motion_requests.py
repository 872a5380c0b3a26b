"""The Slamware node's motion and localization requests: velocity, goals, moves and
rotations, going home, cancelling, setting the pose and recovering localization."""

from __future__ import annotations

import math
import time

from ...bus.topics import Message, RequestRejected
from ...robot.backend import ACTION_PREFIX
from ...robot.capabilities import Robot
from ...robot.model import (
    ActionDirection,
    LocalizationMovement,
    MoveOptions,
    Point2D,
    Pose2D,
    Rect,
)
from ...robot.motion import GOAL_FLAGS
from ...robot.relocalization import GOOD_QUALITY, settled_quality
from ..base import require_finite
from ..ground import messages as m
from ..ground.claims import MotionClaims, who
from ..ground.drive_lease import Verdict
from ..ground.placement import target_problem
from ..ground.slamware_params import SlamwareParams
from .driving import Driving, moving
from .fields import enum_field, move_options, point, quaternion_yaw
from .runner import Request, Runner
from .topics import PKG

VELOCITY_ACTION = "VelocityControlAction"
"""What a robot calls the action ``/cmd_vel`` runs (a drive superseding a drive takes nothing
over)."""
MANUAL_ACTIONS = (VELOCITY_ACTION, "MoveByAction")
"""Actions a stop may end: manual driving (a REST robot drives by hand with short MoveBys)."""
DRIVE_GAP = 0.25
"""s: commands this close together are one drive (publishers send at 10 Hz or more)."""


class MotionRequests:
    """Moves the robot (through the locomotion gate) as the real node's request topics ask."""

    def __init__(self, runner: Runner, robot: Robot, claims: MotionClaims | None = None,
                 driving: Driving | None = None):
        """``driving``: the robot's drive lease (None: any client drives, as a tool's node)."""
        self.runner, self.robot = runner, robot
        self.claims = claims or MotionClaims()
        self.driving = driving
        self._drove_at = -math.inf

    def requests(self, p: SlamwareParams, simple_goals: bool = True) -> list[Request]:
        """The request topics; ``simple_goals`` False leaves ``goal_topic`` to move_base."""
        goal = (m.slamware_topic(p.goal_topic), "geometry_msgs/PoseStamped", self._on_goal)
        return [
            (m.slamware_topic(p.vel_control_topic), "geometry_msgs/Twist", self._on_cmd_vel),
            *([goal] if simple_goals else []),
            ("set_pose", "geometry_msgs/Pose", self._on_set_pose),
            ("recover_localization", f"{PKG}/RecoverLocalizationRequest", self._on_recover),
            ("move_by_direction", f"{PKG}/MoveByDirectionRequest", self._on_move_by_direction),
            ("move_by_theta", f"{PKG}/MoveByThetaRequest", self._on_move_by_theta),
            ("move_to", f"{PKG}/MoveToRequest", self._on_move_to),
            ("move_to_locations", f"{PKG}/MoveToLocationsRequest", self._on_move_to_locations),
            ("rotate_to", f"{PKG}/RotateToRequest", self._on_rotate_to),
            ("rotate", f"{PKG}/RotateRequest", self._on_rotate),
            ("go_home", f"{PKG}/GoHomeRequest", self._on_go_home),
            ("cancel_action", f"{PKG}/CancelActionRequest", self._on_cancel),
        ]

    def _on_cmd_vel(self, message: Message) -> None:
        t = message.msg
        is_moving = moving(t)
        linear, angular = t["linear"]["x"], t["angular"]["z"]
        # the lease's guard refused another's command before it got here: this asks again
        verdict = Verdict.DRIVE if self.driving is None else \
            self.driving.verdict(message.origin, is_moving)
        if verdict is Verdict.IDLE_STOP:
            self.runner.run(message, "cmd_vel", lambda: self._idle_stop(message))
            return
        motion = self.robot.motion

        async def drive() -> None:
            # who ended the running action, asked once per drive (not of every command of it)
            if is_moving and time.monotonic() - self._drove_at > DRIVE_GAP:
                running = await motion.get_current_action()
                if running is not None and not running.action_name.endswith(VELOCITY_ACTION):
                    self.claims.took_over(running.action_id, who(message.origin, "a /cmd_vel"))
            if is_moving:
                self._drove_at = time.monotonic()
            await motion.set_velocity(linear, angular)

        self.runner.run(message, "cmd_vel", drive)

    async def _idle_stop(self, message: Message) -> None:
        """A stop from someone not driving (a watcher, the lease's end): it stops manual
        driving, but never reaches the robot while a goal, a patrol or a task runs (on a
        Slamware robot any velocity command supersedes the running action)."""
        motion = self.robot.motion
        running = await motion.get_current_action()
        if running is not None and not running.action_name.endswith(MANUAL_ACTIONS):
            message.reply.info(
                f"cmd_vel: a stop from a client that is not driving leaves the running "
                f"{running.action_name.removeprefix(ACTION_PREFIX)} alone (cancel_action "
                f"stops it)")
            return
        await motion.set_velocity(0.0, 0.0)

    def _placed(self, what: str, targets: list[Point2D]) -> None:
        """Refuse targets on an obstacle of ``/map`` or nearer one than the robot's clearance
        (ground/placement.py), before the robot moves."""
        for i, target in enumerate(targets):
            name = "goal" if len(targets) == 1 else f"location {i}"
            if problem := target_problem(self.runner.node.bus, name, target.x, target.y):
                raise RequestRejected(f"{what}: {problem}")

    def _on_goal(self, message: Message) -> None:
        p = message.msg["pose"]
        target = point(p["position"], "pose.position")
        yaw = quaternion_yaw(p["orientation"], "pose.orientation")
        self._placed("move_base_simple/goal", [target])
        self.runner.run(message, "move_base_simple/goal", lambda: self.robot.motion.move_to(
            [target], MoveOptions(flags=GOAL_FLAGS), yaw))

    def _on_set_pose(self, message: Message) -> None:
        msg = message.msg
        point(msg["position"], "position")
        pose = Pose2D(msg["position"]["x"], msg["position"]["y"],
                      quaternion_yaw(msg["orientation"], "orientation"))

        async def set_pose() -> None:
            """Forced as the SDK does, but the publisher learns whether the robot agrees."""
            await self.robot.localization.set_pose(pose)
            quality = await settled_quality(self.robot.localization)
            if quality >= GOOD_QUALITY:
                message.reply.ok(f"set_pose: localized (quality {quality})")
            else:
                message.reply.warn(f"set_pose: the pose was set but localization has not "
                                   f"converged (quality {quality} < {GOOD_QUALITY}); use "
                                   "/set_initialpose or recover_localization")

        self.runner.run(message, "set_pose", set_pose)

    def _on_recover(self, message: Message) -> None:
        msg = message.msg
        a = msg["area"]
        require_finite("area", a["x"], a["y"], a["w"], a["h"])
        area = Rect(a["x"], a["y"], a["w"], a["h"])
        opts = msg["options"]
        max_time = opts["max_time_ms"]["value"] if opts["max_time_ms"]["is_valid"] else None
        if max_time is not None and max_time <= 0:
            raise RequestRejected("field 'options.max_time_ms.value' must be positive")
        movement = None
        if opts["mvmt_type"]["is_valid"]:
            movement = enum_field("options.mvmt_type.value.type",
                                  opts["mvmt_type"]["value"]["type"], LocalizationMovement)
        localization = self.robot.localization
        self.runner.run(message, "recover_localization",
                        lambda: localization.recover_localization(
                            None if area.is_empty else area, max_time, movement))

    def _on_move_by_direction(self, message: Message) -> None:
        msg = message.msg
        direction = enum_field("direction.direction", msg["direction"]["direction"],
                               ActionDirection)
        opts = move_options(msg["options"])
        self.runner.run(message, "move_by_direction",
                        lambda: self.robot.motion.move_by_direction(direction, opts))

    def _on_move_by_theta(self, message: Message) -> None:
        msg = message.msg
        require_finite("theta", msg["theta"])
        opts = move_options(msg["options"])
        self.runner.run(message, "move_by_theta",
                        lambda: self.robot.motion.move_by_theta(float(msg["theta"]), opts))

    def _on_move_to(self, message: Message) -> None:
        msg = message.msg
        target = point(msg["location"], "location")
        require_finite("yaw", msg["yaw"])
        opts = move_options(msg["options"])
        self._placed("move_to", [target])
        self.runner.run(message, "move_to",
                        lambda: self.robot.motion.move_to([target], opts, float(msg["yaw"])))

    def _on_move_to_locations(self, message: Message) -> None:
        msg = message.msg
        if not msg["locations"]:
            raise RequestRejected("field 'locations' must not be empty")
        targets = [point(p, f"locations[{i}]") for i, p in enumerate(msg["locations"])]
        require_finite("yaw", msg["yaw"])
        opts = move_options(msg["options"])
        self._placed("move_to_locations", targets)
        self.runner.run(message, "move_to_locations",
                        lambda: self.robot.motion.move_to(targets, opts, float(msg["yaw"])))

    def _on_rotate_to(self, message: Message) -> None:
        msg = message.msg
        yaw = quaternion_yaw(msg["orientation"], "orientation")
        opts = move_options(msg["options"])
        self.runner.run(message, "rotate_to", lambda: self.robot.motion.rotate_to(yaw, opts))

    def _on_rotate(self, message: Message) -> None:
        msg = message.msg
        angle = quaternion_yaw(msg["rotation"], "rotation")
        opts = move_options(msg["options"])
        self.runner.run(message, "rotate", lambda: self.robot.motion.rotate(angle, opts))

    def _on_go_home(self, message: Message) -> None:
        self.runner.run(message, "go_home", self.robot.motion.go_home)

    def _on_cancel(self, message: Message) -> None:
        async def cancel() -> None:
            stopped = await self.robot.motion.cancel_action()
            what = "nothing to cancel" if stopped is None else \
                f"cancelled {stopped.action_name.removeprefix(ACTION_PREFIX)}"
            message.reply.ok(f"cancel_action: {what}")

        self.runner.run(message, "cancel_action", cancel)

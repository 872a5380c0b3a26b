"""``slamware_ros_sdk_server_node`` on the bus: the real node's topics, services and tf.

The node only talks to a :class:`~hitrobot_server.robot.capabilities.Robot`'s capabilities;
whether that is the simulator or a real robot over REST is not its business. Like the real
node, each publisher is a worker with its own period (≤ 0 disables it) and requests arrive on
topics; unlike the real node, a request we cannot carry out is reported to the client that sent
it as a ``status`` error.

The node wires its parts, one module each: the topic names (:mod:`.topics`), the publishers
(:mod:`.publishers`), the copy of the robot's map (:mod:`.map_copy`), the motion requests
(:mod:`.motion_requests`) and the map requests and services (:mod:`.map_requests`), which
check their fields with :mod:`.fields` and run through :mod:`.runner`.
"""

from __future__ import annotations

from ...bus.core import Bus
from ...robot.capabilities import Robot
from ...state import StateBinding
from ..base import RobotNode
from ..ground import messages as m
from ..ground.claims import MotionClaims
from ..ground.memory import NodeMemory
from ..ground.names import TF
from ..ground.slamware_params import SlamwareParams
from .driving import NAMES as LEASE_NAMES
from .driving import Driving
from .map_copy import MapCopy
from .map_requests import MapRequests
from .motion_requests import MotionRequests
from .publishers import Publishers
from .runner import Runner
from .topics import NODE_NAME, PKG, SlamwareTopics, global_names


class SlamwareNode(RobotNode):
    """Publishes the robot's state and executes requests exactly where the real node does."""

    GLOBAL_NAMES = (*global_names(SlamwareParams()), *LEASE_NAMES)

    def __init__(self, bus: Bus, robot: Robot, params: SlamwareParams | None = None, *,
                 simple_goals: bool = True, state: StateBinding | None = None,
                 claims: MotionClaims | None = None, authenticate: bool = False):
        """``simple_goals``: drive the goals of ``goal_topic`` itself, as the real node does;
        False when a ``/move_base`` node beside it takes them (the assembly decides).
        ``state``: the robot's state folder (the extent of a cleared map is kept there).
        ``claims``: where a ``/cmd_vel`` that takes the robot over is noted (shared with the
        nodes whose goals it may end). ``authenticate``: clients log in (only an admin may
        then take the drive lease over)."""
        super().__init__(bus, NODE_NAME, robot.link)
        self.robot = robot
        p = self.params = params or SlamwareParams()
        for name, value in p.as_dict().items():
            bus.params.set(f"{NODE_NAME}/{name}", value)
        self.topics = SlamwareTopics.of(p)
        for topic, type_name, latch in (*self.topics.advertised(),
                                        (TF, "tf2_msgs/TFMessage", False)):
            self.advertise(topic, type_name, latch=latch)
        self.map_copy = MapCopy(self, robot, p, self.topics, NodeMemory(state, "slamware"))
        self.publishers = Publishers(self, robot, p, self.topics, self.map_copy)
        runner = Runner(self, robot.motion)
        self.map_requests = MapRequests(runner, robot, self.map_copy)
        self.driving = Driving(self, m.slamware_topic(p.vel_control_topic), authenticate)
        motion = MotionRequests(runner, robot, claims, self.driving).requests(p, simple_goals)
        for topic, type_name, handler in (*motion, *self.map_requests.requests()):
            self.subscribe(m.slamware_topic(topic), type_name, handler)
        velocity = self.bus.topic(m.slamware_topic(p.vel_control_topic))
        if velocity is not None:
            self.driving.guard(velocity)
        self.service(m.slamware_topic("sync_get_stcm"), f"{PKG}/SyncGetStcm",
                     self.map_requests.sync_get_stcm)
        self.service(m.slamware_topic("sync_set_stcm"), f"{PKG}/SyncSetStcm",
                     self.map_requests.sync_set_stcm)

    async def start(self) -> None:
        self.publishers.start()

    async def stop(self) -> None:
        self.driving.close()
        await super().stop()

"""``/system_shell``: the seed's custom string commands (§4.1) and the system mode (§4.2).

Commands arrive as ``std_msgs/String`` on ``/cmd_string`` or ``/system_shell/cmd_string`` (the
JavaScript example's name); both behave the same. The mode (``gmapping``, ``navigation``, or
``busy`` while switching) is published, latched, on ``/ros_mode`` and
``/system_shell/system_mode``. A command we cannot carry out is reported to the client that
sent it as a ``status`` error; so is an unknown command.

==================  ===========================================================================
``shutdown``        the robot (never the host running this server) powers off and stays off;
                    role admin only when the server runs with ``--authenticate``
``reboot``          the robot restarts: offline now, back shortly with a fresh state; role admin
                    only with ``--authenticate``
``cancel``          cancel every ``/move_base`` goal and stop the robot's current motion
``gmapping``        mapping mode: ``busy``, map updates on, then ``gmapping``
``navigation``      navigation mode: ``busy``, map frozen (updates off), then ``navigation``
``save_map``        ``map_messages/SaveMap {filename: "localization"}`` → /map_manager/save_map
``save_map_edit``   ``{filename: "navigation"}`` → /map_manager/save_map
``save_as_map``     ``{filename: "localization"}`` → /map_manager/load_map
``save_as_map_edit``  ``{filename: "navigation"}`` → /map_manager/load_map
``version``         server and robot versions, latched on ``/system_shell/version``
``null``            nothing (an empty string too)
==================  ===========================================================================
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable

from .. import __version__
from ..bus.core import Bus
from ..bus.errors import BusError
from ..bus.topics import Message, RequestRejected
from ..robot.backend import BackendError
from ..robot.capabilities import Robot
from ..types.convert import default_message
from .base import RobotNode
from .ground.names import MAP_MANAGER_LOAD_MAP, MAP_MANAGER_SAVE_MAP
from .ground.pacing import Pace
from .ground.requests import answer, require_robot, robot_error

log = logging.getLogger(__name__)

NODE_NAME = "/system_shell"
COMMAND_TOPICS = ("/cmd_string", f"{NODE_NAME}/cmd_string")
MODE_TOPICS = ("/ros_mode", f"{NODE_NAME}/system_mode")
VERSION_TOPIC = f"{NODE_NAME}/version"
GMAPPING, NAVIGATION, BUSY = "gmapping", "navigation", "busy"
MAP_REQUESTS = {
    "save_map": (MAP_MANAGER_SAVE_MAP, "localization"),
    "save_map_edit": (MAP_MANAGER_SAVE_MAP, "navigation"),
    "save_as_map": (MAP_MANAGER_LOAD_MAP, "localization"),
    "save_as_map_edit": (MAP_MANAGER_LOAD_MAP, "navigation"),
}
MAP_REQUEST_TYPE = "map_messages/SaveMap"
MODE_POLL = 0.5
"""Seconds between looks at the robot's map-update switch, so ``/ros_mode`` follows changes made
by other means (``set_map_update``, a robot reboot)."""
ADMIN = "admin"


class ShellNode(RobotNode):
    """Executes ``/cmd_string`` commands against the robot and publishes the mode."""

    GLOBAL_NAMES = (NODE_NAME, *COMMAND_TOPICS, *MODE_TOPICS, "/shell")

    def __init__(self, bus: Bus, robot: Robot, authenticate: bool = False,
                 cancel_goals: Callable[[str], int] | None = None):
        super().__init__(bus, NODE_NAME, robot.link)
        self.robot = robot
        self.authenticate = authenticate
        self.cancel_goals = cancel_goals  # move_base's: cancels its goals, says how many
        self.mode: str | None = None
        self._switching = asyncio.Lock()
        self._generation = 0
        for topic in MODE_TOPICS:
            self.advertise(topic, "std_msgs/String", latch=True)
        self.advertise(VERSION_TOPIC, "std_msgs/String", latch=True)
        for topic in COMMAND_TOPICS:
            self.subscribe(topic, "std_msgs/String", self._on_command)
        self.commands: dict[str, Callable[[Message], None]] = {
            "shutdown": lambda msg: self._power(msg, "shutdown"),
            "reboot": lambda msg: self._power(msg, "reboot"),
            "cancel": self._cancel,
            GMAPPING: lambda msg: self._switch(msg, GMAPPING),
            NAVIGATION: lambda msg: self._switch(msg, NAVIGATION),
            **{name: (lambda msg, name=name: self._map_request(msg, name))
               for name in MAP_REQUESTS},
            "version": lambda msg: self.spawn(self._version(msg)),
            "null": lambda msg: None,
            "": lambda msg: None,
        }

    async def start(self) -> None:
        self.every(MODE_POLL, self._follow_robot_mode,  # 2 Hz while the mode is read
                   pace=Pace(self.bus.demand, MODE_TOPICS, MODE_POLL))

    # ------------------------------------------------------------------ mode
    def _publish_mode(self, mode: str) -> None:
        self.mode = mode
        for topic in MODE_TOPICS:
            self.publish(topic, {"data": mode})

    async def _follow_robot_mode(self) -> None:
        if self._switching.locked():
            return
        generation = self._generation
        mode = GMAPPING if await self.robot.maps.get_map_update() else NAVIGATION
        if self._switching.locked() or generation != self._generation:
            return  # a switch started meanwhile: it publishes the mode itself
        if mode != self.mode:
            self._publish_mode(mode)

    def _switch(self, message: Message, mode: str) -> None:
        require_robot(self.link, mode)
        self.spawn(self._do_switch(message, mode))

    async def _do_switch(self, message: Message, mode: str) -> None:
        async with self._switching:
            self._generation += 1
            self._publish_mode(BUSY)
            try:
                await self.robot.localization.set_localization_enabled(True)
                await self.robot.maps.set_map_update(mode == GMAPPING)
            except BackendError as exc:
                message.reply.fail(f"{mode}: {robot_error(exc)}")
                try:
                    actual = GMAPPING if await self.robot.maps.get_map_update() else NAVIGATION
                except BackendError:
                    actual = None
                if actual is not None:
                    self._publish_mode(actual)
                else:
                    self.mode = None  # unknown until the robot answers again
                return
            self._publish_mode(mode)

    # ------------------------------------------------------------------ commands
    def _on_command(self, message: Message) -> None:
        command = message.msg["data"].strip()
        handler = self.commands.get(command)
        if handler is None:
            known = ", ".join(c for c in self.commands if c)
            raise RequestRejected(f"unknown command '{command}'; known commands: {known}")
        handler(message)

    def _power(self, message: Message, command: str) -> None:
        origin = message.origin
        if self.authenticate and origin is not None and origin.role != ADMIN:
            raise RequestRejected(f"{command}: only clients of role '{ADMIN}' may {command} "
                                  f"the robot (yours: '{origin.role}')")
        require_robot(self.link, command)

        async def power() -> str:
            who = origin.node if origin is not None else "an in-process node"
            log.warning("robot %s requested by %s", command, who)
            if command == "shutdown":
                await self.robot.power.power_off()
            else:
                await self.robot.reboot()
            return "the robot is going down"

        self.spawn(answer(message.reply, command, power()))

    def _cancel(self, message: Message) -> None:
        goals = 0
        if self.cancel_goals is not None:
            goals = self.cancel_goals("cancelled by /cmd_string cancel")
        if goals and not self.link.connected:
            return
        require_robot(self.link, "cancel")

        async def stop_motion() -> None:
            await self.robot.motion.cancel_action()

        self.spawn(answer(message.reply, "cancel", stop_motion()))

    def _map_request(self, message: Message, command: str) -> None:
        """Ask the map manager on the client's behalf (its origin goes with the request, for
        authorisation and the audit trail) and relay the manager's answer to the client."""
        topic_name, filename = MAP_REQUESTS[command]
        topic = self.bus.topic(topic_name)
        try:
            if topic is None or self not in topic.publishers:
                topic = self.bus.advertise(topic_name, MAP_REQUEST_TYPE if topic is None else None,
                                           self, self.name)
        except BusError as exc:
            raise RequestRejected(f"{command}: cannot request it from the map manager: {exc}"
                                  ) from None
        if not topic.subscribers:
            raise RequestRejected(f"{command}: the map manager is not running (nobody listens "
                                  f"on {topic_name})")
        body = default_message(topic.mtype, self.bus.types)
        if "filename" not in body:
            raise RequestRejected(f"{command}: {topic_name} has type "
                                  f"'{self.bus.types.short(topic.type_name)}', not "
                                  f"'{MAP_REQUEST_TYPE}'")
        body["filename"] = filename
        client = message.reply

        def relay(level: str, text: str) -> None:
            """The map manager answers the shell's request; the client hears that answer."""
            client.send(level, text)

        self.bus.publish(topic_name, body, reply=relay, origin=message.origin)

    async def _version(self, message: Message) -> None:
        lines = [f"hitrobot-server {__version__}"]
        try:
            info = await self.robot.sensors.get_device_info()
        except BackendError as exc:
            lines.append(f"robot: {robot_error(exc)}")
        else:
            lines += [
                f"robot: {info.model_name} by {info.manufacturer_name}, device {info.device_id}",
                f"robot hardware: {info.hardware_version}",
                f"robot software: {info.software_version}",
                f"robot sdp: {info.sdp_version}",
                f"robot sdk: {info.sdk_version}",
            ]
        text = "\n".join(lines)
        self.publish(VERSION_TOPIC, {"data": text})
        message.reply.ok(text)

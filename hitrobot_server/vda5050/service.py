"""Every robot of this server a VDA 5050 vehicle: one :class:`Vehicle` and one MQTT link per
robot, and the bus's ``/vda5050/link`` (latched) saying for each whether it is connected, to
which broker, its current order and its last error (the fleet and the console read it).

What a vehicle knows of the site comes off the bus: the loaded map's name (the ``mapId``), the
composed ``/map`` (a node must be where a robot can stand: the POI placement rule), the fleet's
tasks (a robot running one takes no order)."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from importlib.util import find_spec

from ..bus.core import Bus
from ..bus.demand import Passive
from ..nodes.ground.names import FLEET_ROBOTS, MAP_MANAGER_LOADED_MAP, VDA5050_LINK
from ..nodes.ground.placement import placement_problem, site_cells
from ..robot.capabilities import Robot
from .mqtt import MqttLink, base_topic, tls_context
from .options import Vda5050Options
from .schemas import validator
from .vehicle import Vehicle

log = logging.getLogger(__name__)

NODE = "/vda5050"
LINKS_TYPE = "hitrobot_msgs/VdaLinks"
DEFAULT_MAP_ID = "map"
"""The ``mapId`` while no saved map is loaded."""
DEFAULT_SERIAL = "robot"


@dataclass(frozen=True)
class RobotEntry:
    """A robot handed to the service: its name ("" for the single unnamed one), its parts."""

    name: str
    robot: Robot


class Vda5050Service:
    """The vehicles of this server and their links."""

    def __init__(self, bus: Bus, options: Vda5050Options, robots: list[RobotEntry],
                 map_frame: str):
        broker = options.broker
        if broker is None:
            raise ValueError("the VDA 5050 vehicles need --vda5050")
        missing = [name for name in ("aiomqtt", "fastjsonschema") if find_spec(name) is None]
        if missing:
            raise RuntimeError(f"--vda5050 needs {' and '.join(missing)}: pip install "
                               "'hitrobot-server[vda5050]'")
        for topic in ("order", "instantActions"):  # compiled now, not on the first message
            validator(topic)
        self.bus, self.options, self.broker = bus, options, broker
        tls = tls_context(options.vda5050_ca_file, options.vda5050_cert_file,
                          options.vda5050_key_file) if broker.tls else None
        password = options.password()
        self.map_name = ""
        self.tasks: dict[str, int] = {}  # robot → its fleet task
        self.links: list[tuple[str, MqttLink]] = []
        self._shown: dict | None = None
        for entry in robots:
            serial = entry.name or options.vda5050_serial or DEFAULT_SERIAL
            vehicle = Vehicle(bus, entry.robot, entry.name,
                              manufacturer=options.vda5050_manufacturer, serial=serial,
                              map_frame=map_frame, map_id=self.map_id, problem=self.problem,
                              send=lambda *_: None)
            vehicle.on_change = self.show
            link = MqttLink(vehicle, broker, options.vda5050_interface,
                            options.vda5050_manufacturer, password=password, tls=tls)
            self.links.append((entry.name, link))

    async def start(self) -> None:
        self.bus.advertise(VDA5050_LINK, LINKS_TYPE, self, NODE, latch=True)
        self.bus.subscribe(MAP_MANAGER_LOADED_MAP, "std_msgs/String", Passive((self, 1)), NODE,
                           self._loaded)
        self.bus.subscribe(FLEET_ROBOTS, "hitrobot_msgs/FleetRobots", Passive((self, 2)), NODE,
                           self._fleet)
        for _name, link in self.links:
            link.vehicle.start()
            link.start()
        self.show()

    async def stop(self) -> None:
        for _name, link in self.links:
            await link.stop()
            await link.vehicle.stop()
        self.show()
        self.bus.unsubscribe(MAP_MANAGER_LOADED_MAP, Passive((self, 1)))
        self.bus.unsubscribe(FLEET_ROBOTS, Passive((self, 2)))
        self.bus.unadvertise(VDA5050_LINK, self)

    # ------------------------------------------------------------------ from the bus
    def _loaded(self, message) -> None:
        self.map_name = str(message.msg.get("data", ""))

    def _fleet(self, message) -> None:
        for robot in message.msg.get("robots", []):
            self.tasks[robot["name"]] = int(robot.get("task", 0))
        for name, link in self.links:
            link.vehicle.fleet_task = self.tasks.get(name, 0)

    def map_id(self) -> str:
        return self.map_name or DEFAULT_MAP_ID

    def problem(self, x: float, y: float) -> str | None:
        """Why a robot cannot stand at (x, y) on the composed map (None: it can, or no map):
        the POIs' rule (ground/placement.py), on known floor."""
        return placement_problem(site_cells(self.bus), x, y)

    # ------------------------------------------------------------------ to the bus
    def lines(self) -> list[dict]:
        out = []
        for name, link in self.links:
            v = link.vehicle
            status = v.status()
            out.append({
                "robot": name, "serial": v.serial,
                "topic": base_topic(self.options.vda5050_interface,
                                    self.options.vda5050_manufacturer, v.serial),
                "broker": self.broker.url, "connected": link.connected,
                "order_id": status["order_id"], "order_update_id": status["order_update_id"],
                "active": status["active"], "paused": status["paused"],
                "last_error": status["last_error"] or link.last_error})
        return out

    def show(self) -> None:
        """``/vda5050/link`` again, when a line changed."""
        lines = {"links": self.lines()}
        if lines != self._shown and self.bus.topic(VDA5050_LINK) is not None:
            self._shown = lines
            self.bus.publish(VDA5050_LINK, lines)

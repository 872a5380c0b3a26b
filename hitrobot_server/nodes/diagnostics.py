"""``/diagnostics_agg``: the robot's and the bridge's health as ``diagnostic_msgs/DiagnosticArray``.

Published once a second, named the way ``diagnostic_aggregator`` names its output: a summary per
group (``/Robot``, ``/Bridge``) followed by its items. The node runs with or without a robot;
without one only the ``/Bridge`` group is published. While the robot is offline its connection
item is ERROR and the other robot items are STALE.

==========================  ==================================================================
``/Robot/Connection``       OK when reachable, ERROR when not, or when it answers errors or
                            nonsense (the link's ``trouble``: HTTP 500, not JSON, a body
                            over its bound), with the robot's answer as the reason
``/Robot/Battery``          WARN below 15 % (Slamware's "power low"), ERROR below 5 %, unless
                            charging; the charging / dock state in the message and values
``/Robot/Localization``     quality: WARN below 50, ERROR below 30; WARN when disabled
``/Robot/Motion``           the current action and the velocity
``/Robot/Health``           the robot's own warnings and errors (``get_health``)
``/Bridge/Clients``         connected clients (``/hitrobot_client_*`` nodes), topics, services
``/Bridge/Slow links``      WARN while a client's link is too slow for a topic: the messages of
                            that topic it did not get, per client and topic (the bus
                            subscriber's ``dropped`` count; a small topic is never thinned)
``/Bridge/State``           the robot's state folder: "restored from …" or "started fresh in
                            …", the last write, errors (WARN when something was skipped or a
                            write failed); a fleet robot's is among its own ``/Robot`` items
==========================  ==================================================================
"""

from __future__ import annotations

import time

from .. import procmem
from ..bus.core import Bus
from ..bus.graph import whole_graph
from ..bus.names import CLIENT_NODE_PREFIX
from ..robot.backend import ACTION_PREFIX, BackendError, NotConnectedError
from ..robot.capabilities import Robot
from ..robot.model import HealthLevel
from ..state import StateBinding, StateStore
from .base import RobotNode
from .ground import messages as m
from .ground.requests import NOT_CONNECTED

OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_WORDS = {OK: "OK", WARN: "Warning", ERROR: "Error", STALE: "Stale"}
PERIOD = 1.0
BATTERY_LOW = 15
BATTERY_CRITICAL = 5
QUALITY_WARN = 50
QUALITY_ERROR = 30
TOPIC = "/diagnostics_agg"


def status(name: str, level: int, message: str, hardware_id: str = "",
           **values: object) -> dict:
    return {"level": level, "name": name, "message": message, "hardware_id": hardware_id,
            "values": [{"key": k.replace("_", " "), "value": _text(v)}
                       for k, v in values.items()]}


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.3f}"
    return str(value)


def summary(name: str, items: list[dict]) -> dict:
    """A group's summary: ERROR over STALE over WARN over OK, as the aggregator reports."""
    levels = {item["level"] for item in items}
    level = next((lv for lv in (ERROR, STALE, WARN) if lv in levels), OK)
    return status(name, level, LEVEL_WORDS[level])


def memory_item() -> dict:
    """The server's resident memory, its worker processes included (they hold big messages
    while they parse or encode them, outside the server's own RSS)."""
    mem = procmem.memory()
    mb = 1024 * 1024
    return status(
        "/Bridge/Memory", OK,
        f"{mem.total / mb:.0f} MB resident ({mem.worker_count} worker processes: "
        f"{mem.workers / mb:.0f} MB)",
        total_mb=round(mem.total / mb, 1), server_mb=round(mem.main / mb, 1),
        workers_mb=round(mem.workers / mb, 1), workers=mem.worker_count)


class DiagnosticsNode(RobotNode):
    GLOBAL_NAMES = ("/diagnostic_aggregator", TOPIC)

    def __init__(self, bus: Bus, robot: Robot | None = None,
                 state: StateBinding | None = None, bridge: bool = True):
        super().__init__(bus, "/diagnostic_aggregator", robot.link if robot else None)
        self.robot = robot
        self.state = state
        self._device_id = ""
        self._bridge = bridge  # a fleet robot's own diagnostics leave the bridge to the site
        self.advertise(TOPIC, "diagnostic_msgs/DiagnosticArray")

    async def start(self) -> None:
        self.every(PERIOD, self._publish, needs_robot=False)

    async def _publish(self) -> None:
        statuses: list[dict] = []
        if self.robot is not None:
            robot = await self.robot_items()
            if not self._bridge:  # a fleet robot: its state folder with its own items
                robot += self.state_items()
            statuses += [summary("/Robot", robot), *robot]
        if self._bridge:
            bridge = self.bridge_items()
            statuses += [summary("/Bridge", bridge), *bridge]
        self.publish(TOPIC, {"header": m.header("", self.bus.clock()), "status": statuses})

    def bridge_items(self) -> list[dict]:
        bus = self.bus
        # every server's clients (other workers of --workers, servers joined over Zenoh)
        clients = sorted(n for n in whole_graph(bus).nodes if n.startswith(CLIENT_NODE_PREFIX))
        return [status(
            "/Bridge/Clients", OK,
            f"{len(clients)} client{'' if len(clients) == 1 else 's'} connected",
            clients=len(clients), topics=len(bus.topics), services=len(bus.services),
            actions=len(bus.actions), nodes=len(bus.nodes), client_names=" ".join(clients)),
            memory_item(), self.slow_links(), *self.state_items()]

    def state_items(self) -> list[dict]:
        """``/Bridge/State`` once the robot's state folder is known."""
        if self.state is None or self.state.store is None:
            return []
        return [state_item(self.state.store)]

    def slow_links(self) -> dict:
        drops = sorted(
            (node, name, dropped)
            for name, topic in self.bus.topics.items()
            for node, callback in topic.subscribers.values()
            if (dropped := getattr(callback, "dropped", 0))
        )
        item = status("/Bridge/Slow links", WARN if drops else OK,
                      f"{len(drops)} topic(s) thinned for slow clients" if drops
                      else "every client keeps up")
        item["values"] = [{"key": f"{node} {name}", "value": str(dropped)}
                          for node, name, dropped in drops]
        return item

    async def robot_items(self) -> list[dict]:
        assert self.robot is not None
        kind = type(self.robot.link).__name__
        level, text, stale = ERROR, "not connected", f"no data: {NOT_CONNECTED}"
        if self.link.connected:
            try:
                return await self._robot_items(kind)
            except NotConnectedError:
                pass
            except BackendError as exc:
                trouble = self.robot.link.trouble
                level, stale = ERROR, "no data"
                text = (f"the robot answers badly: {trouble}" if trouble
                        else f"the robot does not answer: {exc}")
        hw = self._device_id
        return [status("/Robot/Connection", level, text, hw, backend=kind),
                *(status(f"/Robot/{name}", STALE, stale, hw)
                  for name in ("Battery", "Localization", "Motion", "Health"))]

    async def _robot_items(self, kind: str) -> list[dict]:
        b = self.robot
        assert b is not None
        info = await b.sensors.get_device_info()
        hw = self._device_id = info.device_id
        items = [connection_item(b.link.trouble, hw, backend=kind, model=info.model_name,
                                 software_version=info.software_version)]

        power = await b.power.get_power_status()
        pct = int(power.battery_percentage)
        state = ("charging" if power.is_charging else
                 "on dock" if power.is_dc_in else "discharging")
        level = OK
        if not power.is_charging:
            level = ERROR if pct < BATTERY_CRITICAL else WARN if pct < BATTERY_LOW else OK
        words = {OK: "", WARN: ", low", ERROR: ", critically low"}
        items.append(status(
            "/Robot/Battery", level, f"{pct} %, {state}{words[level]}", hw,
            battery_percentage=pct, charging=power.is_charging, dc_connected=power.is_dc_in,
            docking_status=power.docking_status.value, power_stage=power.power_stage.value,
            sleep_mode=power.sleep_mode.value))

        enabled = await b.localization.get_localization_enabled()
        quality = int(await b.localization.get_localization_quality())
        mapping = await b.maps.get_map_update()
        if not enabled:
            level, text = WARN, "localization disabled"
        elif quality < QUALITY_ERROR:
            level, text = ERROR, f"quality {quality}: localization lost"
        elif quality < QUALITY_WARN:
            level, text = WARN, f"quality {quality}: poor localization"
        else:
            level, text = OK, f"quality {quality}"
        items.append(status("/Robot/Localization", level, text, hw, quality=quality,
                            localization_enabled=enabled, map_update=mapping))

        action = await b.motion.get_current_action()
        odo = await b.sensors.get_odometry()
        if action is None:
            text, values = "idle", {}
        else:
            name = action.action_name.removeprefix(ACTION_PREFIX)
            text = f"{name} ({action.status.name.lower()})"
            values = {"action": name, "action_id": action.action_id, "stage": action.stage}
        items.append(status("/Robot/Motion", OK, text, hw, **values,
                            linear_velocity=odo.twist.vx, angular_velocity=odo.twist.omega))

        health = await b.sensors.get_health()
        temperature = await b.power.get_board_temperature()
        level = OK
        for err in health.errors:
            level = max(level, WARN if err.level == HealthLevel.WARN
                        else ERROR if err.level >= HealthLevel.ERROR else OK)
        text = "; ".join(e.message for e in health.errors) or "no errors"
        errors = {f"{e.level.name.lower()} 0x{e.error_code:08X}": e.message
                  for e in health.errors}
        items.append(status("/Robot/Health", level, text, hw,
                            board_temperature=temperature, **errors))
        return items


def connection_item(trouble: str, hw: str, **values: object) -> dict:
    """``/Robot/Connection`` of a reachable robot: ERROR while it answers badly."""
    if trouble:
        return status("/Robot/Connection", ERROR,
                      f"connected, but the robot answers badly: {trouble}", hw, **values)
    return status("/Robot/Connection", OK, "connected", hw, **values)


def state_item(store: StateStore) -> dict:
    """``/Bridge/State``: where the robot's state lives and how it came back at start."""
    info = store.status()
    restored = store.restored
    text = (f"started fresh in {info['path']}" if restored.fresh
            else f"state restored from {info['path']}")
    last = info["last_write"]
    when = "never" if last is None else time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(last))
    level = ERROR if info["write_error"] else WARN if info["errors"] else OK
    return status("/Bridge/State", level, text, path=info["path"],
                  restored=restored.summary or "nothing", last_write=when,
                  writes=info["writes"], errors=len(store.errors),
                  last_error=info["errors"][-1] if info["errors"] else "",
                  saving="yes" if info["write_error"] is None
                  else f"no: {info['write_error']}")

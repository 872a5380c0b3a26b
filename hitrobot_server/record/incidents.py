"""What counts as an incident, read from the messages the bus already carries (the record floor
knows no robot): a bus tap that calls ``report(cause, detail)`` on the edge of each one.

* ``goal_aborted``: a ROS 1 action's result with status ABORTED (``/move_base/result``, any
  ``*ActionResult``), or a ROS 2 action's goal turning ABORTED in its ``_action/status`` (Nav2's
  ``navigate_to_pose``, ...), once per goal;
* ``link_lost``: the diagnostics' ``Robot/Connection`` item turning ERROR after it was OK;
* ``localization_lost``: the robot's ``RobotBasicState`` localization quality falling under the
  threshold (``--black-box-localization``) after it was over it, with localization on;
* ``emergency_stop``: the diagnostics' ``Robot/Health`` item turning ERROR with an "emergency
  stop" among its errors (how the simulator's ``/sim/emergency_stop`` shows, as a Slamware
  FATAL health error).

Only the robot and the server's own nodes tell of incidents: a message any client published
(or another server, over the Zenoh link: its own black box watches its robot) is no incident,
whatever its topic says, so no client can make the black box write files or make this watch
keep names. The watch keeps the last state of at most :data:`MAX_NAMES` diagnostics items and
state topics each (a robot has two items and one state topic); past it the oldest is forgotten.

Each rule fires on a change (it was fine, now it is not) and is armed again when the thing is
fine again, so a state that stays bad makes one incident; the control's debounce folds what
one incident causes (the link lost, then the goal aborted) into one file.
"""

from __future__ import annotations

import contextlib
from collections import deque
from collections.abc import Callable

from ..bus.tap import ClientOp
from ..bus.topics import Message

ACTIONLIB_ABORTED = 4  # actionlib_msgs/GoalStatus
ACTION_ABORTED = 6  # action_msgs/GoalStatus
DIAGNOSTIC_OK, DIAGNOSTIC_ERROR = 0, 2
CONNECTION_ITEM = "Robot/Connection"
HEALTH_ITEM = "Robot/Health"
EMERGENCY_STOP = "emergency stop"  # in a health error's text (the simulator's, Slamware's)
LOCALIZATION_TYPE = "slamware_ros_sdk/RobotBasicState"
HYSTERESIS = 10  # localization is fine again at the threshold plus this
SEEN_GOALS = 256  # aborted ROS 2 goals remembered (a status list repeats them)
MAX_NAMES = 1024  # diagnostics items (and state topics) whose last state each rule keeps

Report = Callable[[str, str], None]
Rule = Callable[[Message], None]


class IncidentWatch:
    """Watches the bus for incidents; ``report(cause, detail)`` is called on the loop."""

    def __init__(self, report: Report, *, localization_threshold: int = 30):
        self.report = report
        self.threshold = localization_threshold
        self._rules: dict[str, Rule | None] = {}  # topic name → its rule, None for most
        self._connected: dict[str, bool] = {}  # diagnostics item → was it OK last
        self._localized: dict[str, bool] = {}  # state topic → was quality over the threshold
        self._stopped: dict[str, bool] = {}  # health item → was the emergency stop pressed
        self._aborted: deque[tuple[str, bytes]] = deque(maxlen=SEEN_GOALS)

    def message(self, message: Message) -> None:
        if message.origin is not None:  # a client's (or another server's): not ours to tell
            return
        name = message.topic.name
        try:
            rule = self._rules[name]
        except KeyError:
            rule = self._rules[name] = self._rule(name, message.topic.type_name)
        if rule is not None:  # a message not shaped as its type says tells of no incident
            with contextlib.suppress(KeyError, TypeError, ValueError, AttributeError):
                rule(message)

    def client_op(self, op: ClientOp) -> None:
        """Client ops are no incident."""

    def _rule(self, name: str, type_name: str) -> Rule | None:
        if type_name.endswith("ActionResult") and name.endswith("/result"):
            return self._action_result
        if name.endswith("/_action/status") and type_name.startswith("action_msgs/"):
            return self._action_status
        if type_name.startswith("diagnostic_msgs/") and type_name.endswith("DiagnosticArray"):
            return self._diagnostics
        if type_name.replace("/msg/", "/") == LOCALIZATION_TYPE and self.threshold > 0:
            return self._localization
        return None

    # ------------------------------------------------------------------ the rules
    def _action_result(self, message: Message) -> None:
        status = message.msg["status"]
        if int(status["status"]) != ACTIONLIB_ABORTED:
            return
        action = message.topic.name.removesuffix("/result") or "/"
        goal = status.get("goal_id", {}).get("id", "")
        text = status.get("text", "")
        self.report("goal_aborted", f"{action}: goal {goal!r} aborted" +
                    (f": {text}" if text else ""))

    def _action_status(self, message: Message) -> None:
        action = message.topic.name.removesuffix("/_action/status")
        for entry in message.msg["status_list"]:
            if int(entry["status"]) != ACTION_ABORTED:
                continue
            uuid = bytes(entry["goal_info"]["goal_id"]["uuid"])
            if (action, uuid) in self._aborted:
                continue
            self._aborted.append((action, uuid))
            self.report("goal_aborted", f"{action}: goal {uuid.hex()[:8]} aborted")

    def _diagnostics(self, message: Message) -> None:
        for item in message.msg["status"]:
            name = item["name"]
            if name.endswith(CONNECTION_ITEM):
                self._connection(name, _level(item["level"]), item.get("message", ""))
            elif name.endswith(HEALTH_ITEM):
                self._health(name, _level(item["level"]), item.get("message", ""))

    def _connection(self, name: str, level: int, text: str) -> None:
        was = self._connected.get(name)
        if level == DIAGNOSTIC_OK:
            _keep(self._connected, name, True)
        elif level == DIAGNOSTIC_ERROR:
            _keep(self._connected, name, False)
            if was:
                self.report("link_lost", _robot_says(name, CONNECTION_ITEM,
                                                     text or "not connected"))

    def _health(self, name: str, level: int, text: str) -> None:
        stopped = level == DIAGNOSTIC_ERROR and EMERGENCY_STOP in text.lower()
        if stopped and not self._stopped.get(name, False):
            self.report("emergency_stop", _robot_says(name, HEALTH_ITEM, text))
        _keep(self._stopped, name, stopped)

    def _localization(self, message: Message) -> None:
        msg = message.msg
        if not msg["is_localization_enabled"]:
            return
        quality = int(msg["localization_quality"])
        name = message.topic.name
        was = self._localized.get(name, False)
        if quality < self.threshold:
            _keep(self._localized, name, False)
            if was:
                self.report("localization_lost",
                            f"{name}: localization quality {quality} < {self.threshold}")
        elif quality >= min(100, self.threshold + HYSTERESIS):
            _keep(self._localized, name, True)


def _keep(table: dict[str, bool], name: str, value: bool) -> None:
    """``table[name] = value``, the oldest name forgotten past :data:`MAX_NAMES`."""
    if name not in table and len(table) >= MAX_NAMES:
        del table[next(iter(table))]
    table[name] = value


def _level(level: int | bytes) -> int:
    return level[0] if isinstance(level, bytes | bytearray) else int(level)


def _robot_says(item: str, suffix: str, text: str) -> str:
    """``text``, after the robot's name for a fleet robot (its item is /NAME/Robot/...)."""
    robot = item.removesuffix(suffix).strip("/")
    return f"{robot}: {text}" if robot else text

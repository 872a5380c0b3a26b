"""What a vehicle sends (sans-I/O): the header of each topic, ``connection``, ``factsheet``,
``state`` and ``visualization`` built from values (the robot's readings, the order book)."""

from __future__ import annotations

import datetime
from dataclasses import dataclass, field

from .inbox import MAX_ACTIONS, MAX_BYTES, MAX_EDGES, MAX_NODES, MAX_STRING
from .orders import OrderBook
from .schemas import VERSION

ONLINE, OFFLINE, CONNECTIONBROKEN = "ONLINE", "OFFLINE", "CONNECTIONBROKEN"
MIN_STATE_INTERVAL = 0.2
"""Seconds between two states at least (the factsheet's ``minStateInterval``)."""
STATE_INTERVAL = 30.0
"""A state at least this often, changed or not (``defaultStateInterval``)."""
VISUALIZATION_INTERVAL = 0.5
"""Seconds between two visualization messages while the robot drives."""


def timestamp(now: float) -> str:
    """ISO 8601 in UTC with hundredths, as the spec's examples (``1991-03-11T11:40:03.12Z``)."""
    t = datetime.datetime.fromtimestamp(now, datetime.UTC)
    return t.strftime("%Y-%m-%dT%H:%M:%S.") + f"{t.microsecond // 10000:02d}Z"


@dataclass
class Headers:
    """The header of every message one vehicle sends: ``headerId`` counts per topic."""

    manufacturer: str
    serial: str
    counts: dict[str, int] = field(default_factory=dict)

    def stamp(self, topic: str, now: float, body: dict) -> dict:
        n = self.counts.get(topic, -1) + 1
        self.counts[topic] = n
        return {"headerId": n, "timestamp": timestamp(now), "version": VERSION,
                "manufacturer": self.manufacturer, "serialNumber": self.serial, **body}


@dataclass
class Reading:
    """The robot as last read: what ``state`` reports besides the order."""

    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0
    vx: float = 0.0
    omega: float = 0.0
    battery: float = 0.0
    voltage: float | None = None
    charging: bool = False
    localization: float = 0.0  # 0..1
    localized: bool = False
    driving: bool = False
    e_stop: bool = False
    online: bool = False


def connection(headers: Headers, now: float, state: str) -> dict:
    return headers.stamp("connection", now, {"connectionState": state})


def position(r: Reading, map_id: str) -> dict:
    return {"x": r.x, "y": r.y, "theta": r.theta, "mapId": map_id,
            "positionInitialized": r.localized, "localizationScore": r.localization}


def state(headers: Headers, now: float, book: OrderBook, r: Reading, map_id: str) -> dict:
    battery = {"batteryCharge": round(r.battery, 1), "charging": r.charging}
    if r.voltage is not None:
        battery["batteryVoltage"] = r.voltage
    return headers.stamp("state", now, {
        "orderId": book.order_id, "orderUpdateId": book.update_id,
        "lastNodeId": book.last_node_id, "lastNodeSequenceId": book.last_node_seq,
        "nodeStates": book.node_states(), "edgeStates": book.edge_states(),
        "driving": r.driving, "paused": book.paused, "newBaseRequest": False,
        "operatingMode": "AUTOMATIC" if r.online else "SERVICE",
        "agvPosition": position(r, map_id),
        "velocity": {"vx": r.vx, "vy": 0.0, "omega": r.omega},
        "loads": [], "actionStates": book.action_states(), "batteryState": battery,
        "errors": book.errors.list(), "information": [],
        "safetyState": {"eStop": "MANUAL" if r.e_stop else "NONE", "fieldViolation": False},
    })


def visualization(headers: Headers, now: float, r: Reading, map_id: str) -> dict:
    return headers.stamp("visualization", now, {
        "agvPosition": position(r, map_id),
        "velocity": {"vx": r.vx, "vy": 0.0, "omega": r.omega}})


def _parameter(key: str, kind: str, text: str, optional: bool = False) -> dict:
    return {"key": key, "valueDataType": kind, "description": text, "isOptional": optional}


INSTANT, NODE = "INSTANT", "NODE"
BLOCKING = {INSTANT: " Blocking types: NONE, SOFT and HARD are taken; it runs at once.",
            NODE: " Blocking types: NONE, SOFT and HARD are taken; on a node it runs as HARD "
            "(the robot stands until it ends)."}
# The blocking types are said in each description: the 2.0.0 schema's ``blockingTypes`` (an
# array with a string ``enum``) admits no value at all, so a factsheet that had one would fail
# every master's validation.
_ACTIONS = [
    {"actionType": "cancelOrder", "actionScopes": [INSTANT],
     "actionDescription": "stop where the robot is and drop the order"},
    {"actionType": "startPause", "actionScopes": [INSTANT],
     "actionDescription": "stop the robot; the order stays"},
    {"actionType": "stopPause", "actionScopes": [INSTANT],
     "actionDescription": "drive on to the node it was driving to"},
    {"actionType": "initPosition", "actionScopes": [INSTANT],
     "actionDescription": "relocalize the robot near the pose given (scan matching)",
     "actionParameters": [
         _parameter("x", "NUMBER", "metres, map frame"),
         _parameter("y", "NUMBER", "metres, map frame"),
         _parameter("theta", "NUMBER", "radians"),
         _parameter("mapId", "STRING", "the robot's map"),
         _parameter("lastNodeId", "STRING", "the node it stands on", True)]},
    {"actionType": "startCharging", "actionScopes": [INSTANT, NODE],
     "actionDescription": "go to the dock (go-home) and charge; finished once charging"},
    {"actionType": "stopCharging", "actionScopes": [INSTANT, NODE],
     "actionDescription": "finished at once: charging ends when the robot leaves its dock"},
    {"actionType": "stateRequest", "actionScopes": [INSTANT],
     "actionDescription": "send a state now"},
    {"actionType": "factsheetRequest", "actionScopes": [INSTANT],
     "actionDescription": "send the factsheet now"},
]
ACTIONS = [{**a, "actionDescription": f"{a['actionDescription']}.{BLOCKING[a['actionScopes'][-1]]}"}
           for a in _ACTIONS]


def factsheet(headers: Headers, now: float, series: str) -> dict:
    """The type specification, physical parameters, protocol limits and features (every
    action with its scopes and parameters) of a Slamware-class robot behind this server."""
    return headers.stamp("factsheet", now, {
        "typeSpecification": {
            "seriesName": series, "seriesDescription": "hitrobot-server robot (Slamware)",
            "agvKinematic": "DIFF", "agvClass": "CARRIER", "maxLoadMass": 0,
            "localizationTypes": ["NATURAL"], "navigationTypes": ["AUTONOMOUS"]},
        "physicalParameters": {
            "speedMin": 0.0, "speedMax": 0.7, "accelerationMax": 0.5,
            "decelerationMax": 0.5, "heightMin": 0.3, "heightMax": 0.4, "width": 0.4,
            "length": 0.4},
        "protocolLimits": {
            "maxStringLens": {"msgLen": MAX_BYTES, "topicSerialLen": MAX_STRING,
                              "topicElemLen": MAX_STRING, "idLen": MAX_STRING,
                              "idNumericalOnly": False, "enumLen": 32, "loadIdLen": MAX_STRING},
            "maxArrayLens": {"order.nodes": MAX_NODES, "order.edges": MAX_EDGES,
                             "node.actions": MAX_ACTIONS, "edge.actions": 0,
                             "actions.actionsParameters": 8,
                             "instantActions": MAX_ACTIONS, "error.errorReferences": 8},
            "timing": {"minOrderInterval": 0.1, "minStateInterval": MIN_STATE_INTERVAL,
                       "defaultStateInterval": STATE_INTERVAL,
                       "visualizationInterval": VISUALIZATION_INTERVAL}},
        "protocolFeatures": {
            "optionalParameters": [
                {"parameter": "order.nodes.nodePosition", "support": "REQUIRED",
                 "description": "the robot drives to positions"},
                {"parameter": "order.nodes.nodePosition.theta", "support": "SUPPORTED"},
                {"parameter": "order.nodes.nodePosition.allowedDeviationXY",
                 "support": "SUPPORTED"}],
            "agvActions": ACTIONS},
        "agvGeometry": {},
        "loadSpecification": {},
    })

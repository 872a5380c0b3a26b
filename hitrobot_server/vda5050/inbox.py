"""What arrives on ``order`` and ``instantActions``, checked before anything acts (sans-I/O):
size, JSON, the header (version, manufacturer, serial, ``headerId`` per topic), the 2.0.0
schema, and our protocol limits. A message either passes whole, is refused with the error the
spec names (``validationError``), or is ignored (not meant for this vehicle, or a repeat)."""

from __future__ import annotations

from dataclasses import dataclass, field

import orjson

from . import errors as e
from .schemas import MAJOR, problem

MAX_BYTES = 256 * 1024
"""A message larger than this is refused unread (the factsheet's limits fit far below it)."""
MAX_NODES = 1000
MAX_EDGES = MAX_NODES - 1
MAX_ACTIONS = 64
"""Actions per node, per edge and per instantActions message (the factsheet's maxArrayLens)."""
MAX_STRING = 128
"""The factsheet's ``maxStringLens`` for ids (msgLen is :data:`MAX_BYTES`)."""


@dataclass(frozen=True)
class Verdict:
    """One message's fate: ``message`` to act on, or an ``error`` for ``state.errors``, or
    ``ignored`` with why (logged once per kind by the caller)."""

    message: dict | None = None
    error: dict | None = None
    ignored: str = ""
    kind: str = ""  # of an ignored message: "stranger" or "repeat", logged once each


@dataclass
class Inbox:
    """One vehicle's incoming messages; remembers the last ``headerId`` per topic."""

    manufacturer: str
    serial: str
    last_header: dict[str, int] = field(default_factory=dict)

    def take(self, topic: str, payload: bytes) -> Verdict:
        if len(payload) > MAX_BYTES:
            return self._refuse(topic, None, f"the message has {len(payload)} bytes, over the "
                                f"{MAX_BYTES} this vehicle takes (protocolLimits.msgLen)")
        try:
            message = orjson.loads(payload)
        except orjson.JSONDecodeError as exc:
            return self._refuse(topic, None, f"the message is not JSON: {exc}")
        if not isinstance(message, dict):
            return self._refuse(topic, None, "the message is not a JSON object")
        if (message.get("manufacturer"), message.get("serialNumber")) != (
                self.manufacturer, self.serial):
            return Verdict(kind="stranger", ignored=f"{topic}: a message for manufacturer "
                           f"{str(message.get('manufacturer'))[:40]!r}, serial "
                           f"{str(message.get('serialNumber'))[:40]!r} is not for this vehicle")
        version = message.get("version")
        if not isinstance(version, str) or f"v{version.split('.')[0]}" != MAJOR:
            return self._refuse(topic, message, f"version {str(version)[:20]!r} is not 2.x.x")
        if topic == "instantActions":
            message = with_actions(message)
            if not isinstance(message.get("actions"), list):
                return self._refuse(topic, message, "actions: an instantActions message "
                                    "lists its actions")
        too_many = limits(topic, message)
        if too_many:
            return self._refuse(topic, message, too_many)
        why = problem(topic, message)
        if why is not None:
            return self._refuse(topic, message, f"not a valid {topic} message: {why}")
        header = message["headerId"]
        last = self.last_header.get(topic)
        if last is not None and header <= last and header != 0:  # 0: the master began again
            return Verdict(kind="repeat", ignored=f"{topic}: headerId {header} is not above the "
                           f"last one "
                           f"({last}): a repeated or late message")
        self.last_header[topic] = header
        return Verdict(message=message)

    @staticmethod
    def _refuse(topic: str, message: dict | None, why: str) -> Verdict:
        if topic == "order":
            return Verdict(error=e.order_error(e.VALIDATION, why, message))
        header = message.get("headerId") if isinstance(message, dict) else None
        return Verdict(error=e.error(e.VALIDATION, why, topic=topic, headerId=header))


def with_actions(message: dict) -> dict:
    """The actions under 2.0.0's ``actions``: VDA 5050 1.1 (and vda-5050-lib 1.4 in 2.0.0
    mode) names the list ``instantActions``; either is taken, checked by the same schema."""
    if "actions" not in message and "instantActions" in message:
        message = dict(message)
        message["actions"] = message.pop("instantActions")
    return message


def limits(topic: str, message: dict) -> str | None:
    """Why ``message`` is over this vehicle's protocol limits, checked before the schema (whose
    cost grows with the message)."""
    if topic == "order":
        nodes, edges = message.get("nodes"), message.get("edges")
        if isinstance(nodes, list) and len(nodes) > MAX_NODES:
            return f"nodes: {len(nodes)} nodes, over the {MAX_NODES} this vehicle takes"
        if isinstance(edges, list) and len(edges) > MAX_EDGES:
            return f"edges: {len(edges)} edges, over the {MAX_EDGES} this vehicle takes"
        for key in ("orderId", "zoneSetId"):
            if isinstance(message.get(key), str) and len(message[key]) > MAX_STRING:
                return f"{key}: longer than {MAX_STRING} characters"
        return None
    actions = message.get("actions")
    if isinstance(actions, list) and len(actions) > MAX_ACTIONS:
        return f"actions: {len(actions)} actions, over the {MAX_ACTIONS} this vehicle takes"
    return None

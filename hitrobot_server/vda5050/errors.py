"""VDA 5050 errors as ``state.errors`` lists them (sans-I/O): the types the spec names, each
with references a master control can match (topic, headerId, orderId, orderUpdateId, actionId)."""

from __future__ import annotations

from typing import Any

WARNING, FATAL = "WARNING", "FATAL"
VALIDATION = "validationError"
ORDER = "orderError"
ORDER_UPDATE = "orderUpdateError"
NO_ROUTE = "noRouteError"
NO_ORDER_TO_CANCEL = "noOrderToCancel"
INSTANT_ACTION = "instantActionError"
ORDER_ACTION = "orderActionError"
ORDER_CANCELLED = "orderCancelled"
"""Not a type of the spec: an order that someone else ended on the robot (the console)."""
ROBOT = "robotError"
LOCALIZATION = "localizationError"
BLOCKED = "navigationBlocked"

KEPT = 32
"""Errors held at most: the oldest warnings give way first (a flood of bad messages)."""


def refs(**values: Any) -> list[dict]:
    """``errorReferences`` from keyword values (None left out), every value a string."""
    return [{"referenceKey": k, "referenceValue": str(v)} for k, v in values.items()
            if v is not None]


def error(kind: str, description: str, level: str = WARNING, **references: Any) -> dict:
    return {"errorType": kind, "errorLevel": level,
            "errorDescription": description[:500], "errorReferences": refs(**references)}


def order_error(kind: str, description: str, order: dict | None, **more: Any) -> dict:
    """An error about an order: its topic and, when it has them, its ids."""
    order = order if isinstance(order, dict) else {}
    return error(kind, description, topic="order", headerId=order.get("headerId"),
                 orderId=order.get("orderId"), orderUpdateId=order.get("orderUpdateId"), **more)


class Errors:
    """The errors ``state.errors`` shows: added, cleared by kind, bounded at :data:`KEPT`."""

    def __init__(self) -> None:
        self.items: list[dict] = []

    def add(self, item: dict) -> None:
        if item in self.items:
            return
        self.items.append(item)
        while len(self.items) > KEPT:
            oldest = next((e for e in self.items if e["errorLevel"] == WARNING), self.items[0])
            self.items.remove(oldest)

    def clear(self, *kinds: str) -> bool:
        """Drop every error of ``kinds``; True when one was there."""
        before = len(self.items)
        self.items = [e for e in self.items if e["errorType"] not in kinds]
        return len(self.items) != before

    def replace(self, kind: str, items: list[dict]) -> bool:
        """The errors of ``kind`` are now ``items`` (the robot's own, re-read); True on a change."""
        old = [e for e in self.items if e["errorType"] == kind]
        if old == items:
            return False
        self.items = [e for e in self.items if e["errorType"] != kind] + items[:KEPT]
        return True

    def list(self) -> list[dict]:
        return list(self.items)

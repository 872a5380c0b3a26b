"""Base for in-process nodes: they use the bus exactly as a bridge client does."""

from __future__ import annotations

from collections.abc import Callable

from ..bus.core import Bus
from ..bus.services import ActionHandler, ServiceHandler
from ..bus.topics import Message


class Node:
    """A named participant; its registrations are undone by ``close``."""

    def __init__(self, bus: Bus, name: str):
        self.bus = bus
        self.name = name
        self._subs: list[tuple[str, object]] = []
        bus.register_node(name)

    def advertise(self, topic: str, type_name: str, latch: bool = False) -> None:
        self.bus.advertise(topic, type_name, self, self.name, latch=latch)

    def publish(self, topic: str, msg: dict) -> Message:
        return self.bus.publish(topic, msg)

    def subscribe(self, topic: str, type_name: str, callback: Callable[[Message], None]) -> None:
        """``callback`` gets the Message: ``.msg`` is the data; raising RequestRejected or
        calling ``.reject(text)`` later sends the publishing client a status error."""
        key = (self, topic)
        self.bus.subscribe(topic, type_name, key, self.name, callback)
        self._subs.append((topic, key))

    def service(self, name: str, type_name: str, handler: ServiceHandler) -> None:
        self.bus.advertise_service(name, type_name, self, self.name, handler)

    def action(self, name: str, type_name: str, handler: ActionHandler) -> None:
        self.bus.advertise_action(name, type_name, self, self.name, handler)

    def close(self) -> None:
        self.bus.remove_owner(self, [key for _topic, key in self._subs])
        self.bus.unregister_node(self.name)

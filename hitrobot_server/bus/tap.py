"""Observers of everything on the bus (the recorder): every published message, and every
client op that changes the robot, with who sent it.

A tap is called on the event loop for each publish, so it must only hand the message on (to a
queue, a worker); it never blocks and never raises into the bus. A tap that needs topics polled
for it says so with a ``demand(name) -> float | None`` method (the period it asks for, 0 for
the full rate: bus/demand.py); a tap without one asks for nothing.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from .services import Action, Service
from .topics import Message, Origin


@dataclass(frozen=True, slots=True)
class ClientOp:
    """A client's op that reaches the robot: a publish to a topic a server node subscribes, a
    call of a server node's service, or an action goal."""

    op: str  # publish, call_service or send_action_goal
    name: str  # the topic, service or action
    type_name: str
    node: str  # the client's node name
    peer: str  # the connection's address
    auth_level: str | None
    stamp: float  # bus clock, seconds
    who: str = ""  # the name of its token ("" without one)
    role: str = ""  # its role

    @classmethod
    def of(cls, op: str, name: str, type_name: str, origin: Origin, stamp: float) -> ClientOp:
        return cls(op, name, type_name, origin.node, origin.peer, origin.auth_level, stamp,
                   origin.name, origin.role)


def client_op(op: str, name: str, target: Service | Action | None, origin: Origin,
              stamp: float) -> ClientOp | None:
    """The entry for a client's ``call_service`` of ``target`` / ``send_action_goal`` to it,
    when it reaches a server node: a service no bridge client provides, or any action."""
    if target is None or (op == "call_service" and target.client):
        return None
    return ClientOp.of(op, name, target.type_name, origin, stamp)


class BusTap(Protocol):
    def message(self, message: Message) -> None:
        """A message published on the bus, or delivered to it by the Zenoh link (those only
        for topics someone in this process uses: the link brings nothing else). A client's
        publish carries its ``origin``; the tap decides whether it is a client op."""

    def client_op(self, op: ClientOp) -> None:
        """A client's ``call_service`` of a service no client provides, or its
        ``send_action_goal`` (see :class:`ClientOp`; the tap decides what it keeps)."""

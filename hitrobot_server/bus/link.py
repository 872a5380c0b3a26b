"""What the bus expects of a link to other processes (:class:`.zenoh.link.ZenohLink` implements it).

The bus calls the link on local changes and publishes and asks it on a miss; the link
delivers remote messages with :meth:`Topic.fan_out`, never through :meth:`Bus.publish`, so a
message that came from another process is never sent back out (no echo, no ping-pong).
"""

from __future__ import annotations

from collections.abc import Awaitable
from dataclasses import dataclass, field
from typing import Protocol

from .services import Action, Service
from .topics import Message

# rosapi's parameter services: per process, except between the workers of one server.
PARAM_SERVICES = frozenset(
    f"/rosapi/{name}"
    for name in ("get_param", "set_param", "has_param", "delete_param", "search_param",
                 "get_param_names")
)


@dataclass
class RemoteGraph:
    """What the other processes have, as rosapi lists it (names are absolute)."""

    topics: dict[str, str] = field(default_factory=dict)  # name -> type (pkg/msg/Type)
    publishers: dict[str, set[str]] = field(default_factory=dict)  # topic -> node names
    subscribers: dict[str, set[str]] = field(default_factory=dict)
    services: dict[str, tuple[str, str]] = field(default_factory=dict)  # name -> (type, node)
    actions: dict[str, tuple[str, str]] = field(default_factory=dict)
    nodes: set[str] = field(default_factory=set)


class GroupMember(Protocol):
    """What one process's part of a :class:`Group` answers: its role changes, the leader's
    changes (as a follower) and its whole state (as the leader, for a follower catching up)."""

    def role(self, leader: str) -> None:
        """The group's leader is now ``leader`` (this process's id when it leads; "" while
        none is elected)."""

    def apply(self, payload: bytes) -> Awaitable[None]:
        """Apply a change the leader sent (a follower); raise to refuse it."""

    def snapshot(self) -> bytes:
        """The leader's whole state, for a follower that joins or missed a change."""


class Group(Protocol):
    """One role shared by the processes of a site: the first to claim it leads, the others
    follow and take over when it dies (its liveliness goes with it)."""

    me: str  # this process's id

    async def join(self, member: GroupMember) -> None:
        """Take part; returns once this process knows who leads (or that it leads)."""

    async def leave(self) -> None: ...

    async def replicate(self, payload: bytes, timeout: float) -> tuple[int, int]:
        """Send a change to every follower: (followers that applied it, followers asked)."""

    async def fetch(self, timeout: float) -> bytes:
        """The leader's snapshot (``ServiceError`` when it does not answer)."""


class BusLink(Protocol):
    def changed(self, kind: str, name: str) -> None:
        """``kind`` is topic, service, action or node; ``name`` what changed locally."""

    def published(self, message: Message) -> None:
        """A local publish (never called for messages the link itself delivered)."""

    def remote_type(self, topic: str) -> str | None:
        """The type another process publishes or subscribes ``topic`` with."""

    def remote_service(self, name: str) -> Service | None:
        """A proxy whose handler calls the service in the process that provides it."""

    def remote_action(self, name: str) -> Action | None:
        """A proxy whose handler runs the goal in the process that provides the action."""

    def graph(self) -> RemoteGraph: ...

    def group(self, name: str) -> Group:
        """The site-wide role ``name`` shared with the other processes."""

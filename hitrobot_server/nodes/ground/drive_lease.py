"""One driver at a time: the drive lease of one robot, as pure logic over a clock.

Velocity commands (``/cmd_vel`` from any protocol, the console's pad) interleave if two clients
send them; the lease lets one through. The first client to send a moving command takes it; its
moving commands keep it; it lapses :data:`LAPSE` seconds after the holder's last moving command
or when the holder's connection goes. Meanwhile another client's command is refused with the
holder's name; an admin may take the lease over. A stop (a zero command) takes nothing: a tool
that keeps publishing zeros does not hold the robot from others.

The node that carries the commands out asks :meth:`DriveLease.ask` per command, runs
:meth:`DriveLease.expire` when :meth:`DriveLease.due` comes and :meth:`DriveLease.leave` when a
client goes; each change it is told of (a :class:`Change`) says whether the robot must get a
stop (its holder's last command was a moving one).
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass

from ...bus.topics import Origin

LAPSE = 0.5
"""s: a lease ends this long after its holder's last moving command."""
ADMIN = "admin"


def driver_name(origin: Origin) -> str:
    """How a driver is shown: its token's name, else (no ``--authenticate``) its session's node
    (unique per connection)."""
    return origin.name or origin.node


def may_take_over(origin: Origin | None, authenticate: bool) -> bool:
    """Whether ``origin`` may take the lease from its holder: an admin (by role, or by rosauth
    level); anyone on a server that does not authenticate its clients."""
    if origin is None or not authenticate:
        return True
    return origin.role == ADMIN


class Verdict(enum.Enum):
    """What to do with one command."""

    DRIVE = "drive"  # the holder's (or a new holder's) command: carry it out
    REFUSE = "refuse"  # another client holds the lease
    IDLE_STOP = "idle stop"  # a stop from a client that is not driving: harmless only


@dataclass
class Holding:
    """Who holds the lease: their key (the session's node), name, since when, when they last
    sent a moving command and whether their last command moved the robot."""

    key: str
    name: str
    since: float
    last: float
    moving: bool = True


@dataclass(frozen=True)
class Change:
    """The lease changed: who holds it now (None: nobody), who held it, why, and whether the
    robot must get one stop because the one who held it was still driving."""

    holder: Holding | None
    previous: Holding | None
    reason: str
    stop: bool = False


class DriveLease:
    """One robot's drive lease; ``clock`` (seconds, monotonic) is the only time it reads."""

    def __init__(self, clock: Callable[[], float], lapse: float = LAPSE):
        self.clock, self.lapse = clock, lapse
        self.holder: Holding | None = None

    def ask(self, key: str, name: str, moving: bool) -> tuple[Verdict, Change | None]:
        """A command from ``key``: what to do with it, and the lease's change if it made one
        (a lease taken). Run :meth:`expire` first: a lease past its time still holds here."""
        now = self.clock()
        holder = self.holder
        if holder is not None and holder.key != key:
            return Verdict.REFUSE, None
        if holder is not None:  # the holder's own command
            holder.moving = moving
            if moving:
                holder.last = now
            return Verdict.DRIVE, None
        if not moving:
            return Verdict.IDLE_STOP, None
        self.holder = Holding(key, name, now, now)
        return Verdict.DRIVE, Change(self.holder, None, "took the lease")

    def driving(self, key: str) -> bool:
        """Whether ``key`` holds the lease (sent a moving command within the lapse)."""
        return self.holder is not None and self.holder.key == key

    def due(self) -> float | None:
        """When the lease lapses unless renewed (clock time), or None when nobody holds it."""
        return None if self.holder is None else self.holder.last + self.lapse

    def expire(self) -> Change | None:
        """End the lease if its time has come."""
        due = self.due()
        if due is None or self.clock() < due:
            return None
        return self._end("lapsed")

    def leave(self, key: str) -> Change | None:
        """``key``'s connection went: end its lease if it held one."""
        if not self.driving(key):
            return None
        return self._end("disconnected")

    def take(self, key: str, name: str) -> Change:
        """An admin takes the lease (from its holder, if any): the holder's driving stops."""
        previous, now = self.holder, self.clock()
        if previous is not None and previous.key == key:
            return Change(previous, previous, "already held")
        self.holder = Holding(key, name, now, now, moving=False)
        stop = previous is not None and previous.moving
        return Change(self.holder, previous, f"taken over by {name}", stop)

    def _end(self, reason: str) -> Change:
        previous, self.holder = self.holder, None
        assert previous is not None
        return Change(None, previous, reason, previous.moving)

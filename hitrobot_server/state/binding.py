"""Which state folder the robot's nodes write to: known at once for the simulator, only once
a REST robot has said who it is (its device id), and another one if another robot answers at
the same address."""

from __future__ import annotations

from .store import StateStore


class StateBinding:
    """The store of the robot currently attached (``None`` until its identity is known)."""

    def __init__(self, store: StateStore | None = None, identity: str = "") -> None:
        self.store = store
        self.identity = identity
        self.changed_unbound = False
        """Something was changed while no store was bound (a REST robot not yet reached):
        the server's side is newer than any folder's."""

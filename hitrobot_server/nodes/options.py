"""What the nodes need to know of the server's settings.

``demo_services`` is the nodes' own setting (its ``help`` in the metadata makes the flag and
the TOML key). The others are the setting of another layer, handed down by ``config.py``
(so they have no default here: the owner's is the one): the map folder (the store's), the
access rules (the sessions'), the simulated time (the robot's), the ``[slamware]`` table.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..bus.names import GlobFilter, access_filters
from .ground.slamware_params import SlamwareParams


@dataclass(frozen=True, kw_only=True)
class NodeOptions:
    """Options shared by the in-process nodes."""

    # read by the start plan (which nodes start), not by a node
    demo_services: bool = field(default=False, metadata={
        "help": "offer the tutorial servers of the rosbridge test image: the service "
        "/add_two_ints and the action /fibonacci (example_interfaces types), for client test "
        "suites"})
    map_store: Path  # where map folders are saved (routes and graphs live beside it)
    slamware: SlamwareParams = field(default_factory=SlamwareParams)
    authenticate: bool  # the shell refuses privileged commands unless clients log in
    time_scale: float = 1.0  # simulated seconds per wall-clock second (1 for a real robot)
    topics_glob: str | None
    services_glob: str | None
    params_glob: str | None
    topics_filter: GlobFilter = field(init=False, repr=False)
    services_filter: GlobFilter = field(init=False, repr=False)
    params_filter: GlobFilter = field(init=False, repr=False)

    def __post_init__(self) -> None:
        filters = access_filters(self.topics_glob, self.services_glob, self.params_glob)
        for name, value in zip(("topics_filter", "services_filter", "params_filter"), filters,
                               strict=True):
            object.__setattr__(self, name, value)


__all__ = ["NodeOptions", "SlamwareParams"]

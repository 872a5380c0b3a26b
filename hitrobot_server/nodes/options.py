"""What the nodes need to know of the server's settings; the command line builds it."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..bus.names import GlobFilter, access_filters
from .ground.slamware_params import SlamwareParams


@dataclass
class NodeOptions:
    """Options shared by the in-process nodes."""

    map_store: Path  # where map folders are saved (routes and graphs live beside it)
    slamware: SlamwareParams = field(default_factory=SlamwareParams)
    authenticate: bool = False  # the shell refuses privileged commands unless clients log in
    time_scale: float = 1.0  # simulated seconds per wall-clock second (1 for a real robot)
    topics_glob: str | None = None
    services_glob: str | None = None
    params_glob: str | None = None
    demo_services: bool = False  # the tutorial /add_two_ints and /fibonacci servers
    topics_filter: GlobFilter = field(init=False, repr=False)
    services_filter: GlobFilter = field(init=False, repr=False)
    params_filter: GlobFilter = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.topics_filter, self.services_filter, self.params_filter = access_filters(
            self.topics_glob, self.services_glob, self.params_glob
        )


__all__ = ["NodeOptions", "SlamwareParams"]

"""What the nodes need to know of the server's settings.

``demo_services`` is the nodes' own setting (its ``help`` in the metadata makes the flag and
the TOML key). The others are the setting of another layer, handed down by ``config.py``
(so they have no default here: the owner's is the one): the map folder (the store's), the
access rules (the sessions'), the simulated time (the robot's), the ``[slamware]`` table.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

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
    charge_below: float = field(default=25.0, metadata={
        "help": "fleet: a free robot whose battery is below this (%%) is sent to charge"})
    charge_until: float = field(default=90.0, metadata={
        "help": "fleet: a charging robot takes no new task until its battery is back at this (%%)"})
    site_timezone: str = field(default="", metadata={
        "help": "the site's IANA time zone for fleet schedules ('daily 09:00'); empty: the "
        "server's local time zone (default: empty)"})
    # read by the start plan (which robot's map the site's map manager takes), not by a node
    site_map_robot: str = field(default="", metadata={
        "help": "named robots: the robot whose map feeds the site's map manager (its POIs, "
        "masks and the composed /map are the site's, kept in <state-dir>/site/); empty: the "
        "first robot that has one (default: empty)"})
    fleet_clock: Callable[[], float] | None = None  # tests hold the fleet's wall clock
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
        if not 0.0 <= self.charge_below < self.charge_until <= 100.0:
            raise ValueError("--charge-below and --charge-until: 0 <= below < until <= 100")
        if self.site_timezone:
            try:
                ZoneInfo(self.site_timezone)
            except (ZoneInfoNotFoundError, ValueError):
                raise ValueError(f"--site-timezone: unknown time zone "
                                 f"'{self.site_timezone}'") from None
        filters = access_filters(self.topics_glob, self.services_glob, self.params_glob)
        for name, value in zip(("topics_filter", "services_filter", "params_filter"), filters,
                               strict=True):
            object.__setattr__(self, name, value)


__all__ = ["NodeOptions", "SlamwareParams"]

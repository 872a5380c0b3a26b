"""What the bus needs to know of the server's settings: topic lifetimes and the Zenoh link.

Each field's ``help`` (metadata) makes its flag and TOML key, its default is the server's;
``config.py`` only composes the layers' options.
"""

from __future__ import annotations

from dataclasses import dataclass, field

BUSES = ("local", "zenoh")


@dataclass(frozen=True)
class BusOptions:
    """The in-process bus, and whether (and how) it joins others over Zenoh."""

    unregister_timeout: float = field(default=10.0, metadata={
        "help": "seconds an unused topic lingers before it is removed"})
    bus: str = field(default="local", metadata={
        "help": "'local' (this process only) or 'zenoh' (share topics, services and actions "
        "with other servers and rmw_zenoh ROS 2 nodes on the same Zenoh network)"})
    zenoh_config: str | None = field(default=None, metadata={
        "help": "Zenoh session config file (JSON5) for --bus zenoh; replaces the defaults "
        "(peer mode, no multicast scouting)"})
    zenoh_connect: str | None = field(default=None, metadata={
        "help": "comma-separated Zenoh endpoints to connect to, e.g. tcp/127.0.0.1:7447"})
    zenoh_listen: str | None = field(default=None, metadata={
        "help": "comma-separated Zenoh endpoints to listen on, e.g. tcp/127.0.0.1:7447 "
        "(default: tcp/127.0.0.1:0, any free loopback port)"})
    zenoh_domain: int = field(default=0, metadata={
        "help": "ROS domain id: the first chunk of every Zenoh key (as ROS_DOMAIN_ID)"})

    @property
    def zenoh(self) -> bool:
        """Joined to other servers over the Zenoh link."""
        return self.bus == "zenoh"

    def check(self) -> None:
        if self.bus not in BUSES:
            raise ValueError(f"bus must be one of {', '.join(BUSES)}")

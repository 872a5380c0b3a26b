"""Resource names and glob filters.

Clients write names with or without the leading slash (roslibjs 2.x uses relative
``rosapi/x``, 1.x absolute ``/rosapi/x``); the bus keys everything by the absolute form.
"""

from __future__ import annotations

from collections.abc import Iterable
from fnmatch import fnmatchcase

CLIENT_NODE_PREFIX = "/hitrobot_client_"  # every bridge client's node name starts so


def canonical(name: str) -> str:
    """Absolute form of a ROS graph name: leading slash, no trailing slash."""
    name = name.strip()
    if not name.startswith("/"):
        name = "/" + name
    if len(name) > 1:
        name = name.rstrip("/")
    return name


def valid_name(name: str) -> bool:
    """True for a usable graph name: non-empty, no whitespace, no '//' runs."""
    if not name or name.strip() != name or any(c.isspace() for c in name):
        return False
    return "//" not in canonical(name) and canonical(name) != "/"


class GlobFilter:
    """fnmatch allow-list; ``None`` or empty means everything is allowed.

    rosbridge's ``*_glob`` parameters confused users because rosapi leaked or blocked
    everything (rosbridge #296, #331); here one object answers both the op check and the
    rosapi listing, so they cannot disagree.
    """

    def __init__(self, patterns: Iterable[str] | None = None, always: Iterable[str] = ()):
        pats = [p.strip() for p in (patterns or []) if p and p.strip()]
        self.patterns: tuple[str, ...] = tuple(canonical(p) for p in pats)
        self.always: tuple[str, ...] = tuple(always)

    @classmethod
    def parse(cls, text: str | None, always: Iterable[str] = ()) -> GlobFilter:
        """Parse a comma-separated list, tolerating rosbridge's ``"['a', 'b']"`` spelling."""
        if not text:
            return cls(None, always)
        text = text.strip().strip("[]")
        parts = [p.strip().strip("'\"") for p in text.split(",")]
        return cls(parts, always)

    @property
    def active(self) -> bool:
        return bool(self.patterns)

    def allows(self, name: str) -> bool:
        if not self.patterns:
            return True
        name = canonical(name)
        return any(fnmatchcase(name, p) for p in self.patterns + self.always)


def access_filters(
    topics_glob: str | None, services_glob: str | None, params_glob: str | None = None
) -> tuple[GlobFilter, GlobFilter, GlobFilter]:
    """The ``--topics-glob``/``--services-glob``/``--params-glob`` allow-lists, parsed once
    the same way for the session's op checks and rosapi's listings (rosapi stays callable)."""
    return (
        GlobFilter.parse(topics_glob),
        GlobFilter.parse(services_glob, always=("/rosapi/*",)),
        GlobFilter.parse(params_glob),
    )

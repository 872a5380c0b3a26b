"""The server's one gate, shared by every session and the HTTP side: a presented token becomes
a :class:`~..protocol.access.Grant` (or the reason it is refused), and an op is checked against
the client's role (:func:`~..protocol.access.allowed`). Refusals are logged at info (so they
reach ``/rosout``), by the client's name, never with its token.

Wrong tokens are not slowed down: a token is 32 random bytes, so guessing cannot succeed
whatever the rate, and a delay would only hold sockets open. What a flood costs is a hash and
a lookup each; its log lines are bounded to one per address per second (:class:`FailureLog`).
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from typing import Any
from urllib.parse import parse_qs, urlsplit

from ..bus.core import Bus
from ..bus.services import service_caller
from ..bus.topics import Origin
from ..protocol.access import (
    NOBODY,
    WHOAMI,
    WHOAMI_NODE,
    Grant,
    Role,
    RoleTable,
    allowed,
)

log = logging.getLogger(__name__)

Lookup = Callable[[str], Any]
"""A token → its record (with ``name`` and ``role``) or the reason it is refused (a str)."""

MAX_PRESENTED = 512
"""Characters of a presented token read at all (ours are 43); longer is refused unread."""


class FailureLog:
    """One log line per address per second for refused tokens, with how many there were."""

    MAX_ADDRESSES = 1024

    def __init__(self, clock: Callable[[], float] = time.monotonic):
        self._clock = clock
        self._seen: dict[str, tuple[float, int]] = {}  # address -> (since, refused since)

    def refused(self, peer: str, reason: str) -> None:
        now = self._clock()
        since, count = self._seen.get(peer, (float("-inf"), 0))
        if now - since < 1.0:
            self._seen[peer] = (since, count + 1)
            return
        if len(self._seen) >= self.MAX_ADDRESSES:
            self._seen.clear()
        self._seen[peer] = (now, 0)
        more = f" (and {count} more in the last second)" if count else ""
        log.info("token refused from %s: %s%s", peer or "?", reason, more)


class Access:
    """Tokens and roles for one server. ``enabled`` False (no ``--authenticate``): every client
    is admin, a presented token is ignored."""

    def __init__(self, enabled: bool = False, lookup: Lookup | None = None,
                 roles: RoleTable | None = None):
        self.enabled = enabled
        self.lookup = lookup
        self.roles = roles or RoleTable()
        self.failures = FailureLog()

    def admit(self, token: str, peer: str = "") -> Grant | str:
        """The grant of a presented token, or why it is refused (naming no secret)."""
        if len(token) > MAX_PRESENTED:
            reason = f"token refused: longer than {MAX_PRESENTED} characters"
        elif self.lookup is None:
            reason = "token refused: this server has no tokens file"
        else:
            found = self.lookup(token)
            if not isinstance(found, str):
                return Grant(found.name, found.role)
            reason = f"token refused: {found}"
        self.failures.refused(peer, reason)
        return reason

    def role_of(self, origin: Origin) -> Role:
        """The client's role; admin for every client without ``--authenticate``."""
        return self.roles.get(origin.role)

    def check(self, origin: Origin, kind: str, name: str, message: Any = None) -> str | None:
        """None when ``origin`` may do it; else the refusal (logged at info)."""
        if not self.enabled:
            return None
        reason = allowed(self.role_of(origin), kind, name, message)
        if reason is not None:
            log.info("refused %s (%s, role %s, from %s): %s", origin.name or origin.node,
                     origin.node, origin.role or "none", origin.peer or "?", reason)
        return reason

    def http_refusal(self, path: str, authorization: str | None, peer: str = ""
                     ) -> tuple[int, str] | None:
        """None when an HTTP request may have ``path``; else (401, why) without a good
        token, (403, why) when its role lacks the permission."""
        if not self.enabled:
            return None
        token = presented_token(path, authorization)
        if token is None:
            return 401, ("a token is required (--authenticate): send 'Authorization: Bearer "
                         "TOKEN' or add ?token=TOKEN")
        found = self.admit(token, peer)
        if isinstance(found, str):
            return 401, found
        origin = Origin("/http", peer=peer, name=found.name, role=found.role)
        reason = self.check(origin, "http", urlsplit(path).path)
        return None if reason is None else (403, reason)

    def permissions(self, origin: Origin) -> list[str]:
        role = self.role_of(origin) if self.enabled else self.roles.get("admin")
        return sorted(role.permissions)


def unauthenticated(node: str, peer: str) -> Origin:
    """The origin of a client not authenticated yet (``--authenticate``): no role at all."""
    return Origin(node, peer=peer, role=NOBODY.name)


def origin_of(node: str, peer: str, grant: Grant, auth_level: str | None = None) -> Origin:
    return Origin(node, auth_level, peer=peer, name=grant.name, role=grant.role)


def presented_token(path: str, authorization: str | None) -> str | None:
    """The token a request carries: ``Authorization: Bearer T`` or ``?token=T`` (the header
    first); None without one. The query is read only when it is short enough to be one."""
    if authorization:
        scheme, _, value = authorization.strip().partition(" ")
        if scheme.lower() == "bearer" and value.strip():
            return value.strip()
    if "token=" not in path:
        return None
    query = urlsplit(path).query
    if len(query) > 4 * MAX_PRESENTED:
        return "x" * (MAX_PRESENTED + 1)  # refused as too long, never parsed
    values = parse_qs(query).get("token")
    return values[0] if values else None





class WhoAmI:
    """``/hitrobot/whoami`` (``std_srvs/Trigger``, every role may call it): the caller's token
    name, role and permissions as JSON in ``message``, so a console can disable what its role
    lacks."""

    def __init__(self, bus: Bus, access: Callable[[], Access]):
        self.bus = bus
        self.access = access

    async def start(self) -> None:
        self.bus.register_node(WHOAMI_NODE)
        self.bus.advertise_service(WHOAMI, "std_srvs/Trigger", self, WHOAMI_NODE, self._answer)

    def stop(self) -> None:
        self.bus.remove_owner(self)
        self.bus.unregister_node(WHOAMI_NODE)

    async def _answer(self, _request: dict) -> dict:
        access = self.access()
        origin = service_caller() or Origin(WHOAMI_NODE)
        role = origin.role if access.enabled else "admin"
        body = {"name": origin.name, "role": role, "authenticate": access.enabled,
                "permissions": access.permissions(origin)}
        return {"success": True, "message": json.dumps(body)}

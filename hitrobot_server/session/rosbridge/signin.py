"""The rosbridge ``auth`` op: a named token, or rosauth's MAC (its ``level`` mapped to a role:
``admin`` is admin, any other level operator). A refused one closes the connection."""

from __future__ import annotations

import time
from dataclasses import asdict
from typing import Any, Protocol

from ...bus.topics import Origin
from ...protocol import auth as rosauth
from ...protocol import ops
from ...protocol.access import Grant, rosauth_role
from ..options import SessionOptions


class SigningIn(Protocol):
    """What the ``auth`` op uses of a rosbridge session."""

    settings: SessionOptions
    authenticated: bool
    peer: str
    shared: Any  # the server's Shared: access, auth_replays
    origin: Origin

    def status(self, level: str, msg: str, op_id: Any = None) -> None: ...
    def close_connection(self) -> None: ...
    def authorize(self, grant: Grant, auth_level: str | None = None) -> None: ...


def auth(session: SigningIn, op: ops.Auth) -> None:
    """Authenticate ``session`` by ``op``, or refuse it and close."""
    if not session.settings.authenticate:
        session.status("info", "auth: authentication is not enabled; ignored", op.id)
        return
    if session.authenticated:
        session.status("warning", "auth: already authenticated", op.id)
        return
    if op.token is not None:
        _auth_token(session, op)
        return
    missing = [name for name in op.MAC_FIELDS if getattr(op, name) is None]
    if missing:
        session.status("error", f"auth: give 'token', or rosauth's fields (missing: "
                    f"{', '.join(missing)}); closing", op.id)
        session.close_connection()
        return
    now = time.time()
    if not session.settings.auth_secret:  # no --auth-secret-file: no MAC can be right
        session.status("error", "auth: this server takes tokens only (no --auth-secret-file); "
                    "closing", op.id)
        session.close_connection()
    elif not rosauth.verify(asdict(op), session.settings.auth_secret, now):
        session.status("error", "auth: authentication failed; closing", op.id)
        session.close_connection()
    elif not session.shared.auth_replays.use(op.mac, op.t, now):
        session.status("error", "auth: this MAC was already used; closing", op.id)
        session.close_connection()
    else:
        level = op.level or ""
        session.authorize(Grant(f"rosauth:{op.client}", rosauth_role(level)), level)
        session.status("info", f"authenticated at level {level!r} "
                    f"(role {session.origin.role})", op.id)


def _auth_token(session: SigningIn, op: ops.Auth) -> None:
    found = session.shared.access.admit(op.token or "", session.peer)
    if isinstance(found, str):
        session.status("error", f"auth: {found}; closing", op.id)
        session.close_connection()
        return
    session.authorize(found)
    session.status("info", f"authenticated as {found.name!r} (role {found.role})", op.id)

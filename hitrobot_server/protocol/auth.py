"""rosauth-compatible verification of the ``auth`` op.

The MAC is rosauth's: the SHA-512 hex digest of the shared secret followed by the op's fields,
with the times as whole seconds. rosauth compares against its lowercase hex digest, so an
uppercase MAC is rejected here too.
"""

from __future__ import annotations

import hashlib
import hmac
import math
from pathlib import Path

SECRET_LENGTH = 16
"""rosauth refuses secret files whose first line is not exactly this long."""


def compute_mac(
    secret: str, client: str, dest: str, rand: str, t: float, level: str, end: float
) -> str:
    """The 128-character lowercase hex MAC of ``secret + client + dest + rand + t + level +
    end``, with ``t`` and ``end`` written as integer seconds."""
    text = f"{secret}{client}{dest}{rand}{int(t)}{level}{int(end)}"
    return hashlib.sha512(text.encode("utf-8")).hexdigest()


ALLOWED_DELTA = 5.0
"""Seconds ``t`` may differ from the server's clock, either side (rosauth's default)."""


def verify(
    auth_op: dict, secret: str, now: float, allowed_delta: float = ALLOWED_DELTA
) -> bool:
    """Whether an ``auth`` op (already validated by :mod:`.ops`) grants access at ``now``.

    Valid iff ``t`` is within ``allowed_delta`` seconds of ``now`` (either side, as rosauth
    allows for clock skew), ``end`` is still in the future, and the MAC matches in constant
    time. ``t`` and ``end`` may be floats; only their whole seconds count, as in rosauth.
    """
    if not (math.isfinite(auth_op["t"]) and math.isfinite(auth_op["end"])):
        return False  # NaN/Infinity literals reach here through the lenient JSON reader
    t, end = int(auth_op["t"]), int(auth_op["end"])
    if abs(t - now) >= allowed_delta or end <= now:
        return False
    expected = compute_mac(
        secret,
        auth_op["client"],
        auth_op["dest"],
        auth_op["rand"],
        t,
        auth_op["level"],
        end,
    )
    return hmac.compare_digest(auth_op["mac"].encode("utf-8"), expected.encode("ascii"))


class ReplayCache:
    """The MACs already accepted, server-wide, so each ``auth`` op grants access once.

    rosauth accepts a captured op again on any connection while its ``t`` is within the time
    window. A MAC is remembered until its ``t`` leaves the window, after which :func:`verify`
    refuses it anyway, so the cache holds at most the logins of one window.
    """

    def __init__(self, allowed_delta: float = ALLOWED_DELTA) -> None:
        self.allowed_delta = allowed_delta
        self._until: dict[str, float] = {}  # MAC -> when its op stops verifying

    def __len__(self) -> int:
        return len(self._until)

    def use(self, mac: str, t: float, now: float) -> bool:
        """Record ``mac`` (of an op with time ``t``) as used; False if it already was."""
        for old in [m for m, until in self._until.items() if until <= now]:
            del self._until[old]
        if mac in self._until:
            return False
        self._until[mac] = int(t) + self.allowed_delta
        return True


def load_secret(path: str | Path) -> str:
    """The shared secret: the first line of the file at ``path``, stripped.

    Raises ``ValueError`` unless it is exactly :data:`SECRET_LENGTH` characters, as rosauth does.
    """
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    secret = lines[0].strip() if lines else ""
    if len(secret) != SECRET_LENGTH:
        raise ValueError(
            f"auth secret file {path}: the first line must be exactly {SECRET_LENGTH} characters, "
            f"got {len(secret)}"
        )
    return secret

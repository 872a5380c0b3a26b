"""The named tokens of a site: ``<state-dir>/tokens.json``, written by ``hitrobot-server token``
and read by the running server (again whenever the file changes, at most once a second).

Only a token's SHA-256 is stored: a token is 32 random bytes (``secrets.token_urlsafe``), so a
fast hash is enough; a slow password hash protects guessable secrets, which these are not. The
file (0600, written atomically) is a JSON object ``{"tokens": [{"name", "role", "created",
"expires", "sha256"}]}``; ``expires`` is seconds since the epoch or null.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import logging
import os
import secrets
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from .files import atomic_write, make_folder, read_bounded

log = logging.getLogger(__name__)

TOKENS_FILE = "tokens.json"
MAX_FILE_BYTES = 4 * 1024 * 1024
MAX_TOKEN_CHARS = 512
"""A presented token longer than this is refused before it is hashed (ours are 43)."""
RELOAD_EVERY = 1.0  # seconds between looks at the file's mtime and size


class TokenFileError(ValueError):
    """The tokens file cannot be read as a table of tokens (damaged or edited by hand)."""


@dataclass(frozen=True)
class TokenRecord:
    name: str
    role: str
    created: float
    expires: float | None
    sha256: str

    def public(self) -> dict[str, Any]:
        """What ``token list`` shows: everything but the hash."""
        return {k: v for k, v in asdict(self).items() if k != "sha256"}


def token_hash(token: str) -> str:
    return hashlib.sha256(token.encode("utf-8", "surrogatepass")).hexdigest()


def tokens_path(state_root: Path) -> Path:
    return Path(state_root) / TOKENS_FILE


def read_table(path: Path) -> dict[str, TokenRecord]:
    """The tokens by name; an absent file is an empty table. ``TokenFileError`` says what is
    wrong with a damaged one."""
    try:
        data = json.loads(read_bounded(path, MAX_FILE_BYTES))
    except FileNotFoundError:
        return {}
    except (OSError, ValueError) as exc:  # JSONDecodeError and UnicodeDecodeError too
        raise TokenFileError(f"{path}: {exc}") from None
    entries = data.get("tokens") if isinstance(data, dict) else None
    if not isinstance(entries, list):
        raise TokenFileError(f"{path}: expected an object with a 'tokens' list")
    table: dict[str, TokenRecord] = {}
    for index, entry in enumerate(entries):
        record = _record(entry)
        if record is None:
            raise TokenFileError(f"{path}: token #{index + 1} is damaged (needs name, role, "
                                 "created, expires and a 64-hex-digit sha256)")
        table[record.name] = record
    return table


def _record(entry: Any) -> TokenRecord | None:
    if not isinstance(entry, dict):
        return None
    name, role, digest = entry.get("name"), entry.get("role"), entry.get("sha256")
    created, expires = entry.get("created"), entry.get("expires")
    if not (isinstance(name, str) and name and isinstance(role, str) and role
            and isinstance(digest, str) and len(digest) == 64
            and all(c in "0123456789abcdef" for c in digest)
            and isinstance(created, int | float)
            and (expires is None or isinstance(expires, int | float))):
        return None
    return TokenRecord(name, role, float(created), None if expires is None else float(expires),
                       digest)


def write_table(path: Path, table: dict[str, TokenRecord]) -> None:
    """The whole table, atomically (0600); the state folder and its parents made (0700) if
    missing, as the server makes them: a site's first token comes before its first start."""
    path.parent.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    make_folder(path.parent)
    body = {"tokens": [asdict(r) for r in sorted(table.values(), key=lambda r: r.name)]}
    atomic_write(path, (json.dumps(body, indent=1) + "\n").encode())


def add_token(path: Path, name: str, role: str, expires: float | None,
              now: float | None = None) -> str:
    """A new random token for ``name`` (replacing any of that name); only its hash is kept.
    Returns the token: the only time it is seen."""
    table = read_table(path)
    token = secrets.token_urlsafe(32)
    table[name] = TokenRecord(name, role, time.time() if now is None else now, expires,
                              token_hash(token))
    write_table(path, table)
    return token


def revoke_token(path: Path, name: str) -> bool:
    """Remove ``name``'s token; False when there was none."""
    table = read_table(path)
    if table.pop(name, None) is None:
        return False
    write_table(path, table)
    return True


class TokenBook:
    """The server's view of the tokens file: looked up by a token's hash, reloaded when the
    file's mtime or size change (looked at no more than once a second). A damaged file leaves
    the last good table in use, logged once per damage."""

    def __init__(self, path: Path, clock=time.monotonic):
        self.path = Path(path)
        self._clock = clock
        self._seen: tuple[int, int] | None = None  # (mtime_ns, size) of the table in use
        self._looked = float("-inf")
        self._by_hash: dict[str, TokenRecord] = {}
        self.damage = ""  # why the file on disk is not the table in use, if it is not
        self._reload()

    def lookup(self, token: str, now: float | None = None) -> TokenRecord | str:
        """The record of a valid token, else why it is refused (never the token itself)."""
        if len(token) > MAX_TOKEN_CHARS:
            return f"token longer than {MAX_TOKEN_CHARS} characters"
        if self._clock() - self._looked >= RELOAD_EVERY:
            self._reload()
        digest = token_hash(token)
        record = self._by_hash.get(digest)
        if record is None or not hmac.compare_digest(record.sha256, digest):
            return "unknown or revoked token"
        if record.expires is not None and record.expires <= (time.time() if now is None else now):
            return f"token '{record.name}' expired"
        return record

    def _reload(self) -> None:
        self._looked = self._clock()
        try:
            st = os.stat(self.path)
            seen = (st.st_mtime_ns, st.st_size)
        except FileNotFoundError:
            seen = (0, 0)
        except OSError as exc:
            seen = (-1, -1)
            log.debug("tokens file %s: %s", self.path, exc)
        if seen == self._seen:
            return
        self._seen = seen
        try:
            table = read_table(self.path) if seen != (0, 0) else {}
        except TokenFileError as exc:
            if str(exc) != self.damage:
                log.error("tokens file damaged; the last good table stays in use: %s", exc)
            self.damage = str(exc)
            return
        self.damage = ""
        self._by_hash = {r.sha256: r for r in table.values()}
        log.info("tokens: %d in use (%s)", len(table), self.path)

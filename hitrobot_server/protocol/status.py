"""Status levels: which ``status`` ops a client receives, and the ``set_level`` op.

The seed orders the levels ``info`` ⊃ ``warning`` ⊃ ``error``: a client at ``info`` receives
everything, at ``error`` only errors, and at ``none`` nothing. The default is ``error``.
"""

from __future__ import annotations

from .errors import ProtocolError, message_id

LEVELS: tuple[str, ...] = ("info", "warning", "error", "none")
"""Client levels from most to least verbose; a message level is one of the first three."""

DEFAULT_LEVEL = "error"

_RANK = {level: rank for rank, level in enumerate(LEVELS)}


def should_send(client_level: str, message_level: str) -> bool:
    """Whether a status message of ``message_level`` reaches a client set to ``client_level``.

    Raises ``ValueError`` for a level that is not in :data:`LEVELS` (a programming error: client
    input is checked by :func:`set_level` first).
    """
    for level in (client_level, message_level):
        if level not in _RANK:
            raise ValueError(f"unknown status level {level!r}; expected one of {LEVELS}")
    if message_level == "none":
        return False
    return _RANK[message_level] >= _RANK[client_level]


def set_level(op: dict) -> str:
    """The new level requested by a ``set_level`` op.

    The seed says a ``set_level`` with a bad level string is dropped. We drop it too (the
    client's level is unchanged) but still answer with an error naming the field ``level``,
    because every invalid input is reported.
    """
    level = op.get("level")
    if not isinstance(level, str) or level not in _RANK:
        choices = ", ".join(f"'{name}'" for name in LEVELS)
        raise ProtocolError(
            f"set_level: field 'level' must be one of {choices}, got {level!r}",
            message_id(op),
        )
    return level

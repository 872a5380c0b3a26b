"""The ``status`` op: the one exception type of the protocol layer that turns into one, how one
is built, and which ones a client receives (its level, the ``set_level`` op).

Every invalid input is reported to the client (the seed's status level ``error``), so parsers and
validators raise :class:`ProtocolError` and the session renders it with :meth:`to_status`. The
seed orders the levels ``info`` ⊃ ``warning`` ⊃ ``error``: a client at ``info`` receives
everything, at ``error`` only errors, and at ``none`` nothing. The default is ``error``.
"""

from __future__ import annotations

MessageId = str | int | None


def message_id(obj: object) -> MessageId:
    """The ``id`` of a message if it is a valid one (a string or an integer), else ``None``.

    Used to tag an error with the id of the message it concerns without trusting the input.
    """
    if isinstance(obj, dict):
        value = obj.get("id")
        if isinstance(value, str) or (isinstance(value, int) and not isinstance(value, bool)):
            return value
    return None


def status_op(level: str, msg: str, id: MessageId = None) -> dict:
    """Build a ``status`` op; ``id`` is omitted when absent, as the seed's optional field says."""
    op: dict = {"op": "status", "level": level, "msg": msg}
    if id is not None:
        op["id"] = id
    return op


class ProtocolError(Exception):
    """An invalid client message, carrying the id of the interaction it belongs to."""

    def __init__(self, msg: str, id: MessageId = None, level: str = "error") -> None:
        super().__init__(msg)
        self.msg = msg
        self.id = id
        self.level = level

    def to_status(self) -> dict:
        """The ``status`` op that reports this error to the client."""
        return status_op(self.level, self.msg, self.id)


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

"""The one exception type of the protocol layer and the status op it turns into.

Every invalid input is reported to the client (the seed's status level ``error``), so parsers and
validators raise :class:`ProtocolError` and the session renders it with :meth:`to_status`.
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

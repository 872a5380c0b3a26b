"""The way back to whoever published a request on a topic.

Robot nodes take requests on topics (``/cmd_string``, ``move_to``, the map manager's) and often
learn the outcome only after awaiting the robot. A message carries a :class:`Reply` so the node
can still answer; a client hears the answer as a ``status`` op at the level named here.
"""

from __future__ import annotations

from collections.abc import Callable

Status = Callable[[str, str], None]
"""(level, text) → a status message to the publisher: what a publisher hands ``Bus.publish``."""

INFO, WARNING, ERROR = "info", "warning", "error"


class Reply:
    """A request's answer: :meth:`ok`, :meth:`info`, :meth:`warn` or :meth:`fail`.

    ``ok`` (done) and ``info`` (a note that is no failure: cancelled, superseded) both reach a
    client at level ``info``; the names say which one the node meant. A message published
    without a way back (in-process publishers, remote peers) answers nobody.
    """

    __slots__ = ("_listeners",)

    def __init__(self, status: Status | None = None):
        self._listeners: list[Status] = [] if status is None else [status]

    def ok(self, text: str) -> None:
        """The request was carried out."""
        self.send(INFO, text)

    def info(self, text: str) -> None:
        """Something the publisher should know that is no failure."""
        self.send(INFO, text)

    def warn(self, text: str) -> None:
        """Done, or ignored, but not as the publisher meant."""
        self.send(WARNING, text)

    def fail(self, text: str) -> None:
        """The request was refused or could not be carried out, and why."""
        self.send(ERROR, text)

    def send(self, level: str, text: str) -> None:
        """Answer at ``level``; a node relaying another node's answer passes it on as is."""
        for listener in list(self._listeners):
            listener(level, text)

    def observe(self, listener: Status) -> None:
        """Hear the answer too, before the publisher does (a node that acts on another
        node's success, as map files notes a client's map load)."""
        self._listeners.insert(0, listener)

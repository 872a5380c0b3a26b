"""``/rosout``: the server's log records as ``rosgraph_msgs/Log``, so any client shows them.

Operators see the robot's log in rqt_console-like views, Foxglove's log panel or their own
page, and clients that detect the ROS flavour from ``/rosout``'s type (Foxglove, Lichtblick)
find ROS 1. Each record names the node that logged it (a record's ``ros_node`` extra, else its
module's node as registered in :attr:`Bus.log_names`, else the bridge itself) and the topics
that node publishes.

Two guards keep logging from hurting the server: records logged while a batch is being
published (by a subscriber, an encoder, a send buffer) are not published again, so ``/rosout``
can never feed itself; and at most ``RATE`` records a second (bursts of ``BURST``) go out, the
rest are counted and reported in one record.
"""

from __future__ import annotations

import asyncio
import logging
import threading
from collections import deque
from typing import TYPE_CHECKING

from .clock import ros_time

if TYPE_CHECKING:
    from .core import Bus

TOPIC = "/rosout"
SERVER_NODE = "/hitrobot_server"
RATE = 100.0
BURST = 200
MAX_TEXT = 8000  # characters of a record (message plus traceback) published
LEVELS = ((logging.CRITICAL, 16), (logging.ERROR, 8), (logging.WARNING, 4),
          (logging.INFO, 2), (logging.DEBUG, 1))


def ros_level(levelno: int) -> int:
    """rosgraph_msgs/Log level of a Python logging level (FATAL 16 … DEBUG 1)."""
    return next((ros for py, ros in LEVELS if levelno >= py), 1)


class RosoutHandler(logging.Handler):
    """A logging handler publishing on the bus's ``/rosout``; safe to call from any thread."""

    def __init__(self, bus: Bus, level: int | str = logging.INFO):
        super().__init__(level)
        self.bus = bus
        self.loop = asyncio.get_running_loop()
        self._loop_thread = threading.get_ident()
        self._queue: deque[dict] = deque()
        self._scheduled = False
        self._flushing = False
        self._tokens = float(BURST)
        self._refilled = self.loop.time()
        self.dropped = 0
        self._exc_format = logging.Formatter()
        bus.register_node(SERVER_NODE)
        bus.advertise(TOPIC, "rosgraph_msgs/Log", self, SERVER_NODE)

    def close(self) -> None:
        self.bus.unadvertise(TOPIC, self)
        self.bus.unregister_node(SERVER_NODE)
        super().close()

    def emit(self, record: logging.LogRecord) -> None:
        if self._flushing and threading.get_ident() == self._loop_thread:
            return  # logged while publishing /rosout: never fed back into /rosout
        if not self._take_token():
            self.dropped += 1
            return
        try:
            text = record.getMessage()
            if record.exc_info:
                text = f"{text}\n{self._exc_format.formatException(record.exc_info)}"
        except Exception:
            self.handleError(record)
            return
        self._queue.append({
            "stamp": record.created,
            "level": ros_level(record.levelno),
            "logger": record.name,
            "node": getattr(record, "ros_node", None),  # shared code names its node this way
            "msg": text[:MAX_TEXT],
            "file": record.filename,
            "function": record.funcName or "",
            "line": max(0, record.lineno or 0),
        })
        if not self._scheduled:
            self._scheduled = True
            try:
                self.loop.call_soon_threadsafe(self._flush)
            except RuntimeError:  # the loop is closed: the server is gone
                self._queue.clear()

    def _take_token(self) -> bool:
        now = self.loop.time()
        self._tokens = min(float(BURST), self._tokens + (now - self._refilled) * RATE)
        self._refilled = now
        if self._tokens < 1.0:
            return False
        self._tokens -= 1.0
        return True

    def _node_of(self, logger: str) -> str:
        names = self.bus.log_names
        while logger:
            node = names.get(logger)
            if node is not None:
                return node
            logger = logger.rpartition(".")[0]
        return SERVER_NODE

    def _topics_of(self, node: str) -> list[str]:
        return sorted(t.name for t in self.bus.topics.values() if node in t.publishers.values())

    def _flush(self) -> None:
        self._scheduled = False
        if self.bus.topic(TOPIC) is None:
            self._queue.clear()
            return
        self._flushing = True
        try:
            if self.dropped:
                dropped, self.dropped = self.dropped, 0
                self._publish({"stamp": self.bus.clock(), "level": 4, "logger": __name__,
                               "msg": f"{dropped} log record(s) not published on {TOPIC} "
                                      f"(more than {RATE:g} a second)",
                               "file": "", "function": "", "line": 0})
            while self._queue:
                self._publish(self._queue.popleft())
        finally:
            self._flushing = False

    def _publish(self, rec: dict) -> None:
        node = rec.get("node") or self._node_of(rec["logger"])
        self.bus.publish(TOPIC, {
            "header": {"seq": 0, "stamp": ros_time(rec["stamp"]), "frame_id": ""},
            "level": rec["level"],
            "name": node,
            "msg": rec["msg"],
            "file": rec["file"],
            "function": rec["function"],
            "line": rec["line"],
            "topics": self._topics_of(node),
        })

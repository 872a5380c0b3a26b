"""``subscribe`` / ``unsubscribe``: per-client subscriptions with throttle and queue.

A client may subscribe to one topic several times (one per component, each with an id).
The effective parameters follow the seed: lowest throttle_rate, lowest fragment_size,
highest queue_length, strongest compression.

A throttled subscription queues messages between its slots. Whatever ``queue_length`` a client
asks for, the queue holds at most :data:`MAX_QUEUE_LENGTH` messages, and all of one client's
queues together at most ``--send-buffer-limit`` bytes (each message counted at the size of its
JSON publish op, encoded once and shared with JSON subscribers; the oldest go first), so a
subscription cannot be used to make the server hold an unbounded backlog. Messages are encoded
for the subscription's compression only when their slot comes, as before.
"""

from __future__ import annotations

import asyncio
import time
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ...bus.topics import Message, Topic
from ...protocol.errors import ProtocolError
from ...protocol.ops import Subscribe, Unsubscribe
from ...wire.memo import size_of
from .encodings import is_binary, strongest, subscriber_frames
from .publish import TopicNames

if TYPE_CHECKING:
    from .context import OpContext

MAX_QUEUE_LENGTH = 1000
"""Most messages one throttled subscription queues, whatever ``queue_length`` asks for."""


@dataclass(frozen=True, slots=True)
class SubParams:
    throttle_rate: int  # ms
    queue_length: int
    fragment_size: int | None
    compression: str


class ClientSubscription:
    """All subscriptions of one client to one topic spelling; the bus sees one subscriber.

    Keyed by the topic string exactly as the client wrote it, because the outgoing
    ``publish`` must echo that string (roslibjs dispatches on it).
    """

    def __init__(self, client: OpContext, topic_str: str, ops: SubscribeOps):
        self.client = client
        self.ops = ops  # holds the byte count of all this client's queues
        self.topic_str = topic_str
        self.topic: Topic | None = None
        self.params: dict[object, SubParams] = {}
        self.throttle = 0.0
        self.queue_length = 0
        self.fragment_size: int | None = None
        self.compression = "none"
        self._pending: deque[tuple[Message, int]] = deque()  # waiting messages, their bytes
        self.throttle_dropped = 0  # messages dropped from the throttle queue
        self._last_sent = float("-inf")
        self._timer: asyncio.TimerHandle | None = None

    def update(self) -> None:
        ps = list(self.params.values())
        self.throttle = min(p.throttle_rate for p in ps) / 1000.0
        self.queue_length = max(p.queue_length for p in ps)
        sizes = [p.fragment_size for p in ps if p.fragment_size]
        self.fragment_size = min(sizes) if sizes else self.client.settings.max_message_size
        self.compression = strongest(p.compression for p in ps)
        while len(self._pending) > max(self.queue_length, 1):
            self._pop()

    # The bus calls this synchronously for every message; it must never block.
    def __call__(self, message: Message) -> None:
        if self.throttle <= 0:
            self._send(message)
            return
        now = time.monotonic()
        if not self._pending and now - self._last_sent >= self.throttle:
            self._send(message)
            self._last_sent = now
            return
        self._queue(message)
        self._arm(now)

    def _queue(self, message: Message) -> None:
        """Queue a message; a full queue, or this client's queues over their byte limit, drop
        their oldest first (and, with nothing left to drop, the newest)."""
        size = size_of(message)  # an estimate: encoding here puts big maps on the loop
        ops = self.ops
        limit = self.client.settings.send_buffer_limit
        while self._pending and (
            len(self._pending) >= max(self.queue_length, 1) or ops.queued + size > limit
        ):
            self._pop()
        if ops.queued and ops.queued + size > limit:
            self.throttle_dropped += 1
            return
        self._pending.append((message, size))
        ops.queued += size

    @property
    def dropped(self) -> int:
        """Messages of this topic this client did not get (queues full: a slow link); read by
        the diagnostics node, which sees this subscriber on the bus."""
        return self.throttle_dropped + self.client.outbox.drops(self.topic_str)

    def _pop(self) -> Message:
        message, size = self._pending.popleft()
        self.ops.queued -= size
        return message

    def _arm(self, now: float) -> None:
        if self._timer is None:
            delay = max(self._last_sent + self.throttle - now, 0.0)
            self._timer = asyncio.get_running_loop().call_later(delay, self._flush)

    def _flush(self) -> None:
        """Throttle slot reached: send the head of the queue (so a burst's last one arrives)."""
        self._timer = None
        if self._pending:
            self._send(self._pop())
            self._last_sent = time.monotonic()
        if self._pending:
            self._arm(time.monotonic())

    def _send(self, message: Message) -> None:
        frames = subscriber_frames(
            message, self.topic_str, self.compression, self.fragment_size, self.client.frames
        )
        self.client.outbox.put(frames, True, self.topic_str, self.queue_length or None)

    def cancel(self) -> None:
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        while self._pending:
            self._pop()


class SubscribeOps:
    def __init__(self, client: OpContext, topic_names: TopicNames):
        self.client = client
        self.topic_names = topic_names
        self.subs: dict[str, ClientSubscription] = {}
        self.queued = 0  # bytes in all throttle queues of this client

    def subscribe(self, op: Subscribe) -> None:
        c = self.client
        op_id = op.id
        topic_str = op.topic
        name = self.topic_names.check("subscribe", topic_str, op_id)
        compression = op.compression
        if is_binary(compression) and c.transport != "ws":
            c.status(
                "warning",
                f"subscribe: compression '{compression}' needs WebSocket binary frames; "
                "sending JSON on this TCP connection",
                op_id,
            )
            compression = "none"
        queue_length = op.queue_length
        if queue_length > MAX_QUEUE_LENGTH:
            c.status(
                "warning",
                f"subscribe: queue_length {queue_length} clamped to {MAX_QUEUE_LENGTH}; a "
                f"client's throttle queues also hold at most {c.settings.send_buffer_limit} "
                "bytes (--send-buffer-limit), oldest dropped first",
                op_id,
            )
            queue_length = MAX_QUEUE_LENGTH
        params = SubParams(op.throttle_rate, queue_length, c.fragment_size(op), compression)
        type_name = op.type or None
        sub = self.subs.get(topic_str)
        if sub is None:
            sub = ClientSubscription(c, topic_str, self)
            sub.params[op_id] = params
            sub.update()
            try:
                sub.topic = c.bus.subscribe(name, type_name, (c, topic_str), c.node, sub)
            except Exception:
                sub.cancel()
                raise
            self.subs[topic_str] = sub
        else:
            if type_name is not None:  # same checks as a first subscribe, for a clear error
                c.bus.subscribe(name, type_name, (c, topic_str), c.node, sub, replay_latched=False)
            sub.params[op_id] = params
            sub.update()
            topic = sub.topic
            if topic is not None and topic.latched and topic.last is not None:
                sub(topic.last)  # a second component of this client also wants the latched map
        c.status("info", f"subscribed to '{name}'", op_id)

    def unsubscribe(self, op: Unsubscribe) -> None:
        op_id = op.id
        topic_str = op.topic
        sub = self.subs.get(topic_str)
        if sub is None:
            raise ProtocolError(
                f"unsubscribe: not subscribed to topic '{topic_str}'", op_id, level="warning"
            )
        if op_id is not None and op_id in sub.params and len(sub.params) > 1:
            del sub.params[op_id]
            sub.update()
            return
        if op_id is not None and op_id not in sub.params:
            raise ProtocolError(
                f"unsubscribe: no subscription with id {op_id!r} on '{topic_str}'",
                op_id,
                level="warning",
            )
        self._drop(topic_str)
        self.client.status("info", f"unsubscribed from '{topic_str}'", op_id)

    def _drop(self, topic_str: str) -> None:
        sub = self.subs.pop(topic_str)
        sub.cancel()
        self.client.outbox.forget(topic_str)
        if sub.topic is not None:
            self.client.bus.unsubscribe(sub.topic.name, (self.client, topic_str))

    def close(self) -> None:
        for topic_str in list(self.subs):
            self._drop(topic_str)

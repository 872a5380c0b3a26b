"""A Foxglove client without sockets, for the session's tests: frames into ``receive``, the
outbox drained and decoded.

The bus, its bridge nodes and the codec are the real ones (tests/sansio.py's Hub); a frame is
handled by the time ``receive`` returns.
"""

from __future__ import annotations

import asyncio
import json

import orjson

from hitrobot_server.bus.cdr import codec_for
from hitrobot_server.protocol import foxglove as fg
from hitrobot_server.session.foxglove.session import FoxgloveSession
from hitrobot_server.session.foxglove.shared import FoxgloveShared
from hitrobot_server.session.options import SessionOptions


class FoxClient:
    """One Foxglove client: text/binary frames in, the session's frames out (JSON as dicts,
    binary as ``(opcode, bytes)``)."""

    def __init__(self, hub, **options):
        self.bus = hub.bus
        self.shared = getattr(hub, "foxglove", None) or FoxgloveShared.for_bus(hub.bus)
        hub.foxglove = self.shared
        self.session = FoxgloveSession(hub.bus, SessionOptions(**options), self.shared)
        self.codec = codec_for(hub.bus.types)

    def send(self, obj: dict | str | bytes) -> None:
        if isinstance(obj, bytes):
            self.session.receive(obj, binary=True)
        else:
            self.session.receive(obj if isinstance(obj, str) else json.dumps(obj))

    async def frames(self, timeout: float = 5.0):
        frames = await asyncio.wait_for(self.session.outbox.get(), timeout)
        assert frames is not None, "the session closed its outbox"
        self.session.outbox.sent()
        return [orjson.loads(d) if not b else (d[0], d) for d, b in frames]

    async def until(self, pred, what: str, limit: int = 500):
        """The first output matching ``pred`` (binary time frames skipped past), bounded."""
        seen = []
        for _ in range(limit):
            for item in await self.frames():
                if pred(item):
                    return item
                seen.append(item)
        raise AssertionError(f"no {what} in {seen[-10:]}")

    async def op(self, name: str):
        return await self.until(lambda m: isinstance(m, dict) and m.get("op") == name, name)

    async def error(self):
        return await self.until(
            lambda m: isinstance(m, dict) and m.get("op") == "status" and m["level"] == fg.ERROR,
            "error status",
        )

    def channel(self, topic: str) -> dict:
        return self.shared.channel(self.bus.topic(topic))

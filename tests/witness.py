"""The innocent bystander of the hostile-client tests: a second real client that must lose
nothing while another client misbehaves."""

from __future__ import annotations

import asyncio

from .helpers import ProtocolClient, WsClient

TOPIC = "/witness/chatter"


class Witness:
    """Subscribes to :data:`TOPIC` and publishes on it through a second connection, so every
    message sent after :meth:`open` can be counted on arrival."""

    def __init__(self, sub: ProtocolClient, pub: ProtocolClient):
        self.sub = sub
        self.pub = pub
        self.sent = 0

    @classmethod
    async def open(cls, port: int) -> Witness:
        return await cls.on(await WsClient.open(port), await WsClient.open(port))

    @classmethod
    async def on(cls, sub: ProtocolClient, pub: ProtocolClient) -> Witness:
        """A witness on two given connections (sockets, or sessions driven sans-I/O)."""
        await sub.send({"op": "set_level", "id": "lv", "level": "info"})
        await sub.expect(op="status", id="lv")
        await pub.send({"op": "advertise", "topic": TOPIC, "type": "std_msgs/String"})
        await sub.send({"op": "subscribe", "id": "w", "topic": TOPIC, "type": "std_msgs/String"})
        await sub.expect(op="status", id="w")
        return cls(sub, pub)

    async def publish(self, count: int = 1) -> None:
        for _ in range(count):
            await self.pub.send({"op": "publish", "topic": TOPIC,
                                 "msg": {"data": f"m{self.sent}"}})
            self.sent += 1

    async def check(self, timeout: float = 10.0) -> None:
        """Every message published so far arrives, in order, and a service call is answered."""
        await self.publish(1)
        got = []
        while len(got) < self.sent:
            msg = await self.sub.expect(op="publish", topic=TOPIC, timeout=timeout)
            got.append(msg["msg"]["data"])
        assert got == [f"m{i}" for i in range(self.sent)]
        self.sent = 0
        reply = await self.sub.call("/rosapi/get_time", timeout=timeout)
        assert reply["result"] is True, reply

    async def close(self) -> None:
        await asyncio.gather(self.sub.close(), self.pub.close())

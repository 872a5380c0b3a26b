"""The innocent bystander of the hostile-client tests: a second real client that must lose
nothing while another client misbehaves."""

from __future__ import annotations

import asyncio
import threading

from hitrobot_server import procmem
from tests.helpers import ProtocolClient, WsClient

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


class RoundTrips:
    """A witness that calls ``/rosapi/get_time`` every 50 ms (the issue's measure) and keeps
    its worst round trip; each call waits at most ``timeout``. It runs on its own event loop
    in a thread, so the test's own work (building and sending an attack) is not counted as
    the server's."""

    def __init__(self, port: int, timeout: float = 10.0):
        self.port = port
        self.timeout = timeout
        self.worst = 0.0
        self.calls = 0
        self.times: list[float] = []  # every round trip, for a failure's message
        self.error: BaseException | None = None
        self._ready = threading.Event()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=lambda: asyncio.run(self._run()), daemon=True)
        self._thread.start()

    @classmethod
    async def open(cls, port: int) -> RoundTrips:
        witness = cls(port)
        for _ in range(1000):  # its first answer came: it is connected and served
            if witness._ready.is_set() or not witness._thread.is_alive():
                break
            await asyncio.sleep(0.01)
        assert witness._ready.is_set(), f"the witness did not start: {witness.error!r}"
        return witness

    async def _run(self) -> None:
        loop = asyncio.get_running_loop()
        try:
            client = await WsClient.open(self.port)
            try:
                for _ in range(100_000):  # bounded: 50 ms apart, far longer than any test
                    start = loop.time()
                    reply = await client.call("/rosapi/get_time", timeout=self.timeout)
                    assert reply["result"] is True, reply
                    took = loop.time() - start
                    self.worst = max(self.worst, took)
                    self.times.append(round(took, 3))
                    self.calls += 1
                    self._ready.set()
                    if self._stop.is_set():
                        return
                    await asyncio.sleep(0.05)
            finally:
                await client.close()
        except BaseException as exc:  # reported by stop()
            self.error = exc

    async def stop(self) -> float:
        """The worst round trip seen (after at least one more call); the client closed."""
        seen = self.calls
        self._stop.set()
        for _ in range(int(self.timeout / 0.01) + 100):
            if not self._thread.is_alive():
                break
            await asyncio.sleep(0.01)
        assert self.error is None, f"the witness failed: {self.error!r}"
        assert self.calls > seen, "the witness got no answer"
        return self.worst


class MemoryPeak:
    """The server's memory (its process and its workers, from /proc) sampled every 20 ms in
    a thread, so a peak between two awaits of the test is seen too."""

    def __init__(self, pid: int):
        self.pid = pid
        self.base = procmem.memory(pid).total
        self.peak = self.base
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.02):
            self.peak = max(self.peak, procmem.memory(self.pid).total)

    def now(self) -> int:
        return procmem.memory(self.pid).total

    def stop(self) -> int:
        """The growth at the peak over the start, in bytes."""
        self._stop.set()
        self._thread.join(5)
        return self.peak - self.base

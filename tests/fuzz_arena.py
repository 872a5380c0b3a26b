"""One real server for a whole fuzz module: Hypothesis runs its examples synchronously, so the
server, the witness (a client that must lose nothing) and the fuzzing client live on an event
loop in a thread, and each example drives them through :class:`LoopThread`."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Awaitable, Callable, Iterator
from typing import Any

from hitrobot_server.config import Settings
from hitrobot_server.server import HitrobotServer
from tests.witness import Witness


class LoopThread:
    """An event loop in a thread, so Hypothesis' synchronous examples can drive async clients
    of one server that lives for the whole test."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()

    def run(self, coro, timeout: float = 60.0):
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout)

    def stop(self) -> None:
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10)
        self.loop.close()


def arena(open_fuzzer: Callable[[int], Awaitable[Any]]) -> Iterator[tuple]:
    """A module fixture's body: a robot-less server on loopback, a witness and the fuzzing
    client ``open_fuzzer(port)`` makes; yields ``(runner, server, witness, fuzzer)``."""
    runner = LoopThread()

    async def setup():
        server = HitrobotServer(Settings.of(port=0, tcp_port=0, address="127.0.0.1",
                                         robot="none", unregister_timeout=0.2))
        await server.start()
        return server, await Witness.open(server.port), await open_fuzzer(server.port)

    server, witness, fuzzer = runner.run(setup())
    yield runner, server, witness, fuzzer

    async def teardown():
        await witness.close()
        await fuzzer.close()
        await server.stop()

    runner.run(teardown())
    runner.stop()

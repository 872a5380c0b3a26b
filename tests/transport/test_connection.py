"""One connection's life (transport/connection.py) without a socket: a real session on a real
bus, the transport's two ways out (``send_frame``, ``direct``) as lists, its input as a
coroutine the test controls."""

from __future__ import annotations

import asyncio
import json

import pytest

from hitrobot_server.transport.connection import keep_reading, run_session
from tests.helpers import decode_frame
from tests.sansio import Hub


@pytest.fixture
async def hub(tmp_path):
    hub = await Hub(tmp_path / "maps").start()
    yield hub
    await hub.stop()


class Wire:
    """What a transport would have written: by the pump (``sent``) or directly (``direct``)."""

    def __init__(self, keeps_up: bool):
        self.keeps_up = keeps_up
        self.sent: list[dict] = []
        self.direct: list[dict] = []

    async def send_frame(self, data: bytes, binary: bool) -> None:
        self.sent.append(decode_frame(data, binary))

    def write(self, frames: list) -> bool:
        if not self.keeps_up:
            return False
        self.direct += [decode_frame(data, binary) for data, binary in frames]
        return True


async def error_then_close(session) -> None:
    """A client op the session answers with an error status, then the session asks to close
    while the reader stays blocked on a socket that sends nothing."""
    session.receive(json.dumps({"op": "no_such_op"}))
    session.close_connection()
    await asyncio.Event().wait()


async def test_a_session_that_asks_to_close_is_flushed_then_closed(hub):
    """The session's last words (its error status) go out before it is closed, and the
    reader still blocked on input is cancelled."""
    session = hub.open().session
    wire = Wire(keeps_up=False)

    await run_session(session, error_then_close(session), sock=None, send_frame=wire.send_frame,
                      direct=wire.write, delay=0.0)
    assert session.closed
    assert [m["op"] for m in wire.sent] == ["status"] and wire.sent[0]["level"] == "error"


async def test_the_client_going_away_closes_the_session(hub):
    """The reader ends (the peer closed): the session is closed, what it held on the bus is
    released, and the pump waiting on its outbox is not left behind."""
    session = hub.open().session
    wire = Wire(keeps_up=True)

    async def read() -> None:
        session.receive(json.dumps({"op": "subscribe", "topic": "/rosout",
                                    "type": "rosgraph_msgs/Log"}))
        assert len(hub.bus.topic("/rosout").subscribers) == 1

    await run_session(session, read(), sock=None, send_frame=wire.send_frame,
                      direct=wire.write, delay=0.0)
    assert session.closed
    topic = hub.bus.topic("/rosout")
    assert topic is None or not topic.subscribers


@pytest.mark.parametrize("delay, direct", [(0.0, True), (0.001, False)])
async def test_direct_writes_only_without_a_delay_between_messages(hub, delay, direct):
    """While the socket keeps up a reply is written at once; with ``--delay-between-messages``
    every frame goes through the pump, which spaces them."""
    session = hub.open().session
    wire = Wire(keeps_up=True)

    await run_session(session, error_then_close(session), sock=None, send_frame=wire.send_frame,
                      direct=wire.write, delay=delay)
    written = wire.direct if direct else wire.sent
    assert [m["op"] for m in written] == ["status"]
    assert (wire.sent if direct else wire.direct) == []


async def test_keep_reading_stops_once_the_session_closed(hub):
    session = hub.open().session
    assert await keep_reading(session)
    session.close_connection()
    assert not await keep_reading(session)

"""The wire floor sits above the bus and below session/ and record/ (tests/test_architecture.py
holds the rule): the bus importing the wire is reported, the wire importing the bus and the
session importing the wire are not; and the wire knows no protocol, so it imports neither
protocol/ nor a session."""

from __future__ import annotations

from tests.test_architecture import violations


def test_the_wire_floor_sits_between_the_bus_and_the_session():
    core = ["hitrobot_server", "bus", "core"]
    assert violations("from ..wire.memo import size_of\n", core, False)
    assert violations("import hitrobot_server.wire.frames\n", core, False)
    assert not violations("from ..bus.topics import Message\n",
                          ["hitrobot_server", "wire", "memo"], False)
    assert not violations("from ..wire.frames import PendingFrames\n",
                          ["hitrobot_server", "session", "outbox"], False)
    assert not violations("from ..wire.memo import PUBLISHED_JSON\n",
                          ["hitrobot_server", "record", "recorder"], False)
    assert violations("from ..session.offload import run\n",
                      ["hitrobot_server", "wire", "frames"], False)


def test_the_wire_floor_knows_no_protocol():
    """A protocol's encodings are its own package's keys: the wire imports no protocol/ (png,
    cbor, Foxglove frames) and no session package."""
    memo = ["hitrobot_server", "wire", "memo"]
    assert violations("from ..protocol import cbor\n", memo, False)
    assert violations("from ..session.rosbridge.frames import FrameBuilder\n", memo, False)
    assert violations("from ..protocol.foxglove import message_data\n", memo, False)

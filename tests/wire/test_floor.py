"""The wire floor sits above the bus and below session/ and record/ (tests/test_architecture.py
holds the rule): the bus importing the wire is reported, the wire importing the bus and the
session importing the wire are not."""

from __future__ import annotations

from ..test_architecture import violations


def test_the_wire_floor_sits_between_the_bus_and_the_session():
    core = ["hitrobot_server", "bus", "core"]
    assert violations("from ..wire.encoded import Seed\n", core, False)
    assert violations("import hitrobot_server.wire.frames\n", core, False)
    assert not violations("from ..bus.topics import Message\n",
                          ["hitrobot_server", "wire", "encoded"], False)
    assert not violations("from ..wire.frames import FrameBuilder\n",
                          ["hitrobot_server", "session", "session"], False)
    assert not violations("from ..wire.encoded import encoded_of\n",
                          ["hitrobot_server", "record", "recorder"], False)
    assert violations("from ..session.offload import run\n",
                      ["hitrobot_server", "wire", "frames"], False)

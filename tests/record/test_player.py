"""The player on a bus, without sockets: pacing to the end, restart, topics it leaves out."""

from __future__ import annotations

import asyncio
import logging

from hitrobot_server.bus.core import Bus
from hitrobot_server.record.player import Player
from hitrobot_server.record.reading import load_recording
from hitrobot_server.record.recorder import Recorder
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import until


async def make_recording(path, count: int = 20, period: float = 0.02) -> None:
    bus = Bus(TypeRegistry.default())
    bus.advertise("/chatter", "std_msgs/String", "t", "/t")
    bus.advertise("/count", "std_msgs/Int32", "t", "/t")
    bus.advertise("/record/state", "hitrobot_msgs/RecordState", "t", "/t", latch=True)
    recorder = Recorder(bus, path)
    recorder.start()
    t0 = bus.clock()
    bus.publish("/record/state", {"recording": True}, stamp=t0)
    for i in range(count):
        bus.publish("/chatter", {"data": str(i)}, stamp=t0 + i * period)
        bus.publish("/count", {"data": i}, stamp=t0 + i * period)
    await recorder.stop()


async def test_plays_to_the_end_then_resume_starts_over(tmp_path):
    path = tmp_path / "r.mcap"
    await make_recording(path)
    bus = Bus(TypeRegistry.default())
    got: list[str] = []
    states: list[dict] = []
    bus.subscribe("/chatter", "std_msgs/String", "k", "/k", lambda m: got.append(m.msg["data"]))
    bus.subscribe("/replay/state", "hitrobot_msgs/ReplayState", "s", "/s",
                  lambda m: states.append(m.msg))
    recording = await asyncio.to_thread(load_recording, path, bus.types)
    assert abs(recording.duration - 0.38) < 1e-6
    player = Player(bus, recording, speed=4.0, play=True)
    await player.start()
    try:
        await until(lambda: states and states[-1]["paused"], "the end", 5)
        assert got == [str(i) for i in range(20)]
        assert states[-1]["position"] == recording.duration
        reply = await bus.call_service("/replay/resume", {})
        assert reply["success"]
        await until(lambda: len(got) == 40, "a second pass", 5)
        assert got[20:] == got[:20]
    finally:
        await player.stop()
    assert "/replay/seek" not in bus.services


async def test_topics_it_cannot_serve_are_left_out(tmp_path, caplog):
    path = tmp_path / "r.mcap"
    await make_recording(path, count=3)
    bus = Bus(TypeRegistry.default())
    bus.advertise("/count", "std_msgs/String", "other", "/other")  # another type already
    recording = await asyncio.to_thread(load_recording, path, bus.types)
    assert "/record/state" not in {t.topic for t in recording.tracks.values()}
    got: list[str] = []
    bus.subscribe("/chatter", "std_msgs/String", "k", "/k", lambda m: got.append(m.msg["data"]))
    player = Player(bus, recording, speed=10.0, play=True)
    with caplog.at_level(logging.WARNING):
        await player.start()
    try:
        await until(lambda: len(got) == 3, "the chatter", 5)
        assert "/count is not replayed" in caplog.text
        assert bus.topic("/count").type_name == "std_msgs/msg/String"
    finally:
        await player.stop()


async def test_it_waits_paused_for_a_client_not_for_the_servers_own_nodes(tmp_path):
    path = tmp_path / "r.mcap"
    await make_recording(path, count=3)
    bus = Bus(TypeRegistry.default())
    recording = await asyncio.to_thread(load_recording, path, bus.types)
    player = Player(bus, recording, speed=10.0)
    got: list[str] = []
    bus.subscribe("/chatter", "std_msgs/String", "node", "/some_node", lambda m: got.append("n"))
    await player.start()
    try:
        assert player.paused and player.waiting and player.clock() == recording.start_ns / 1e9
        state = await bus.call_service("/replay/pause", {})  # a round trip: still at 0
        assert state["message"] == "paused at 0.000 s" and not got
        bus.subscribe("/count", "std_msgs/Int32", "c", "/hitrobot_client_7", lambda m: None)
        assert not player.paused and not player.waiting  # a client came: it plays
        await until(lambda: len(got) == 3, "the chatter", 5)
    finally:
        await player.stop()

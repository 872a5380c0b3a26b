"""The black box (``--black-box``) against real servers: a goal that aborts leaves a file naming
it, ``/record/snapshot`` writes the buffer on demand within its MB bound, SIGTERM writes one,
and each file reads back with the stock ROS 2 MCAP reader."""

from __future__ import annotations

import asyncio
from collections import Counter
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from hitrobot_server.record.blackbox_file import METADATA
from tests.helpers import ServerProcess, WsClient, round_trip
from tests.witness import MemoryPeak

AWAY = (100.0, 100.0)  # a goal far off the map: move_base aborts it at once


def read_back(path: Path) -> tuple[dict[str, str], Counter, list]:
    """The file's incident metadata, its messages per topic and every decoded message, read
    with the stock reader (mcap + mcap-ros2-support): every message must decode."""
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        decoded = [(channel.topic, msg) for _s, channel, _m, msg in
                   reader.iter_decoded_messages()]
        incident = next(m.metadata for m in reader.iter_metadata() if m.name == METADATA)
    return incident, Counter(topic for topic, _msg in decoded), decoded


def black_box_files(folder: Path) -> list[Path]:
    return sorted(folder.glob("blackbox-*.mcap"))


async def test_a_goal_that_aborts_leaves_a_black_box_file_naming_it(make_server, tmp_path):
    folder = tmp_path / "recordings"
    server = await make_server(robot="sim", black_box=30.0,
                               record_dir=str(folder), map_dir=str(tmp_path / "maps"))
    client = await WsClient.open(server.port)
    try:
        await client.send({"op": "subscribe", "topic": "/record/incident"})
        await client.send({"op": "advertise", "topic": "/move_base/goal",
                           "type": "move_base_msgs/MoveBaseActionGoal"})
        await client.send({"op": "publish", "topic": "/move_base/goal", "msg": {
            "goal_id": {"id": "away"},
            "goal": {"target_pose": {"header": {"frame_id": "map"}, "pose": {
                "position": {"x": AWAY[0], "y": AWAY[1]}, "orientation": {"w": 1.0}}}}}})
        incident = (await client.expect(lambda m: m["msg"]["cause"] != "", op="publish",
                                        topic="/record/incident", timeout=60))["msg"]
        assert incident["cause"] == "goal_aborted", incident
        assert "/move_base: goal 'away' aborted" in incident["detail"]
        assert "no free space near the target" in incident["detail"]
        assert incident["count"] == 1
        name = incident["file"]
        assert name.startswith("blackbox-") and name.endswith("goal_aborted.mcap")

        metadata, topics, decoded = read_back(folder / name)
        assert metadata["cause"] == "goal_aborted" and "'away'" in metadata["detail"]
        results = [msg for topic, msg in decoded if topic == "/move_base/result"]
        assert [(r.status.goal_id.id, r.status.status) for r in results] == [("away", 4)]
        assert topics["/scan"] > 0 and topics["/odom"] > 0 and topics["/tf"] > 0
        assert topics["/map"] == 1  # latched: the file opens with it, for a replay

        listed = (await client.call("/record/list"))["values"]["files"]
        assert name in listed  # the server's own recordings list shows it
        incidents = (await client.call("/record/incidents"))["values"]
        assert incidents["files"] == [name] and incidents["causes"] == ["goal_aborted"]
        assert incidents["details"] == [incident["detail"]]
        assert incidents["sizes"] == [(folder / name).stat().st_size]
    finally:
        await client.close()


async def test_a_snapshot_on_demand_keeps_the_latest_within_its_mb_bound(make_server,
                                                                        tmp_path):
    folder = tmp_path / "recordings"
    server = await make_server(black_box=60.0, black_box_max_mb=1, record_dir=str(folder))
    client = await WsClient.open(server.port)
    try:
        too_long = await client.call("/record/snapshot", {"reason": "x" * 201})
        assert not too_long["result"] and "field 'reason'" in too_long["values"]
        status = await client.expect(op="status", id=too_long["id"])
        assert status["level"] == "error"
        assert black_box_files(folder) == []  # refused: nothing written

        await client.send({"op": "advertise", "topic": "/blob", "type": "std_msgs/String"})
        count, size = 600, 4000  # 2.4 MB published: more than twice the bound
        for i in range(count):
            await client.send({"op": "publish", "topic": "/blob",
                               "msg": {"data": f"{i:06d}" + "x" * (size - 6)}})
        reply = await client.call("/record/snapshot", {"reason": "the operator asked"},
                                   timeout=60)  # the writer process may still be starting
        assert reply["result"] and reply["values"]["success"], reply
        contents = server.black_box.box.contents
        assert contents.bytes <= 1024 * 1024
        assert server.black_box.box.bytes <= 1024 * 1024

        path = folder / reply["values"]["path"]
        metadata, topics, decoded = read_back(path)
        assert metadata["cause"] == "snapshot" and metadata["detail"] == "the operator asked"
        kept = [int(msg.data[:6]) for topic, msg in decoded if topic == "/blob"]
        assert kept == list(range(count - len(kept), count))  # the newest, in order
        assert 100 < len(kept) < 1024 * 1024 // size + 1  # evicted by bytes, not all kept
        listed = (await client.call("/record/list"))["values"]["files"]
        assert path.name in listed
    finally:
        await client.close()


def test_sigterm_writes_one_shutdown_file(tmp_path):
    """SIGTERM (as systemd stops the service): one file, cause shutdown, with what the buffer
    held; the server still exits 0."""
    folder = tmp_path / "recordings"
    server = ServerProcess("--black-box", "30", "--record-dir", str(folder))
    try:
        async def publish() -> None:
            client = await WsClient.open(server.port)
            try:
                await client.send({"op": "advertise", "topic": "/chatter",
                                   "type": "std_msgs/String"})
                for i in range(5):
                    await client.send({"op": "publish", "topic": "/chatter",
                                       "msg": {"data": f"hi {i}"}})
                snapshot = await client.call("/record/snapshot", {"reason": "before"},
                                             timeout=60)  # its writer process is up
                assert snapshot["values"]["success"], snapshot
            finally:
                await client.close()

        asyncio.run(publish())
    finally:
        server.stop()  # SIGTERM, then waits for the process to end
    assert server.proc.returncode == 0
    files = [f for f in black_box_files(folder) if not f.name.endswith("-snapshot.mcap")]
    assert [f.name.endswith("-shutdown.mcap") for f in files] == [True], files
    metadata, _topics, decoded = read_back(files[0])
    assert metadata["cause"] == "shutdown"
    assert [msg.data for topic, msg in decoded if topic == "/chatter"] == [
        f"hi {i}" for i in range(5)]


async def test_a_replay_of_a_file_not_in_the_folder_is_refused(make_server, tmp_path):
    """/record/replay starts nothing for a name outside the recordings folder or absent."""
    folder = tmp_path / "recordings"
    server = await make_server(record_dir=str(folder))
    client = await WsClient.open(server.port)
    try:
        for name, words in (("../escape", "field 'name' may hold only letters, digits"),
                            ("absent", "field 'name': no recording absent.mcap")):
            reply = await client.call("/record/replay", {"name": name})
            assert not reply["result"] and words in reply["values"], reply
            status = await client.expect(op="status", id=reply["id"])
            assert status["level"] == "error" and words in status["msg"]
        assert server.replays is not None and server.replays.process is None
    finally:
        await client.close()


async def test_a_clients_fake_incidents_make_no_file_and_leave_no_names(make_server, tmp_path):
    """Issue 52, item 2: aborted results and failing Connection / Health items published by a
    client (a thousand distinct item names) are no incident: nothing gathers, nothing is
    kept; the robot's own incidents still are (the first test)."""
    folder = tmp_path / "recordings"
    server = await make_server(robot="sim", black_box=30.0, record_dir=str(folder))
    client = await WsClient.open(server.port)
    try:
        await client.send({"op": "advertise", "topic": "/move_base/result",
                           "type": "move_base_msgs/MoveBaseActionResult"})
        await client.send({"op": "advertise", "topic": "/diagnostics",
                           "type": "diagnostic_msgs/DiagnosticArray"})
        await client.send({"op": "publish", "topic": "/move_base/result", "msg": {
            "status": {"goal_id": {"id": "fake"}, "status": 4, "text": "made up"}}})
        for i in range(1000):
            for level, text in ((0, "connected"), (2, "emergency stop pressed")):
                await client.send({"op": "publish", "topic": "/diagnostics", "msg": {
                    "status": [{"level": level, "name": f"/r{i}/Robot/Connection",
                                "message": text},
                               {"level": level, "name": f"/r{i}/Robot/Health",
                                "message": text}]}})
        await round_trip(client, timeout=30)  # every publish handled (the watch is a tap)
        control = server.black_box
        assert control._pending is None and control.count == 0 and control.suppressed == 0
        kept = {*control.watch._connected, *control.watch._stopped}
        assert kept <= {"/Robot/Connection", "/Robot/Health"}, len(kept)  # the robot's own
        assert black_box_files(folder) == []
    finally:
        await client.close()


@pytest.mark.serial  # the memory figure: run alone (tests/run.py)
async def test_a_snapshot_flood_is_answered_without_keeping_memory(tmp_path):
    """100 /record/snapshot calls at once from one real client: every one answered, the ones
    that came while a file was written share it, the server's memory comes back."""
    folder = tmp_path / "recordings"
    server = ServerProcess("--black-box", "30", "--record-dir", str(folder), robot="sim")
    try:
        client = await WsClient.open(server.port)
        first = await client.call("/record/snapshot", {"reason": "warm"}, timeout=60)
        assert first["values"]["success"], first  # the writer process is up
        memory = MemoryPeak(server.proc.pid)
        for i in range(100):
            await client.send({"op": "call_service", "id": f"s{i}",
                               "service": "/record/snapshot", "args": {"reason": f"r{i}"}})
        replies = [await client.expect(op="service_response", timeout=60) for _ in range(100)]
        after = memory.now() - memory.base
        memory.stop()
        assert all(r["values"]["success"] for r in replies), replies[0]
        names = {r["values"]["path"] for r in replies}
        assert len(names) <= 10 and all((folder / n).is_file() for n in names)
        assert after < 50_000_000, f"+{after / 1e6:.0f} MB after the flood"
        await client.close()
    finally:
        server.stop()

"""``--record``: 8 s of the simulator driving, read back with the reference readers (``mcap`` and
``mcap-ros2-support``, not our decoder); a recording cut by SIGKILL; an unwritable path."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections import defaultdict
from pathlib import Path

import pytest
import roslibpy
import yaml
from mcap.exceptions import McapError
from mcap.reader import NonSeekingReader, make_reader
from mcap_ros2.decoder import DecoderFactory

from hitrobot_server.record.profile import AUDIT_TOPIC
from tests.helpers import connect_roslibpy
from tests.record.conftest import ODOM, SCAN, rate, record_server


def read_all(path: Path):
    """Every message of the file decoded by mcap-ros2-support, per topic."""
    decoded = defaultdict(list)
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        for _schema, channel, message, msg in reader.iter_decoded_messages():
            decoded[channel.topic].append((message.log_time, msg))
    return summary, decoded


def test_the_recording_reads_back_with_the_reference_readers(drive):
    path, live = drive
    summary, decoded = read_all(path)
    with open(path, "rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert metadata["hitrobot-server"]["ROS_DISTRO"] == "jazzy"
    durability = {}
    for channel in summary.channels.values():
        schema = summary.schemas[channel.schema_id]
        assert (schema.encoding, channel.message_encoding) == ("ros2msg", "cdr")
        assert schema.name.split("/")[1] == "msg"
        qos = yaml.safe_load(channel.metadata["offered_qos_profiles"])
        durability[channel.topic] = qos[0]["durability"]
    assert durability["/map"] == "transient_local" and durability[SCAN] == "volatile"
    for topic in ("/tf", "/map", SCAN, ODOM, "/slamware_ros_sdk_server_node/scan",
                  "/slamware_ros_sdk_server_node/odom"):
        assert decoded.get(topic), f"{topic} not recorded"
    # every message decoded, the audit channel's too (a pure ROS 2 recording)
    assert sum(map(len, decoded.values())) == summary.statistics.message_count
    assert decoded[AUDIT_TOPIC]
    assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
    assert all(c.message_end_time - c.message_start_time <= 1e9 for c in summary.chunk_indexes)
    # the robot drove, and the stamps are the messages' own
    first, last = decoded[ODOM][0][1], decoded[ODOM][-1][1]
    moved = math.dist((first.pose.pose.position.x, first.pose.pose.position.y),
                      (last.pose.pose.position.x, last.pose.pose.position.y))
    assert moved > 0.5
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec / 1e9 for _t, m in decoded[ODOM]]
    assert stamps == sorted(stamps)
    grid = decoded["/map"][-1][1]
    assert len(grid.data) == grid.info.width * grid.info.height > 0
    # rates within 20 % of what a live client received
    for topic in (ODOM, SCAN):
        recorded = rate([t / 1e9 for t, _m in decoded[topic]])
        assert abs(recorded - rate(live[topic])) <= 0.2 * rate(live[topic]), topic


def test_the_audit_channel_names_who_changed_the_robot(drive):
    path, _live = drive
    _summary, decoded = read_all(path)
    entries = [m for _t, m in decoded[AUDIT_TOPIC]]
    ops = {(e.op, e.name) for e in entries}
    assert ("publish", "/cmd_vel") in ops
    assert ("call_service", "/planning/clear_waypoints") in ops
    assert not any(name.startswith("/rosapi/") for _op, name in ops)
    assert {e.address for e in entries} == {"127.0.0.1"}
    assert all(e.client.startswith("/hitrobot_client_") for e in entries)


def children(pid: int) -> list[int]:
    tasks = Path(f"/proc/{pid}/task")
    return [int(c) for t in tasks.iterdir() for c in (t / "children").read_text().split()]


def running(pid: int) -> bool:
    """Alive and not a zombie (an orphan's exit may wait for a reaper in a container)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.serial  # the writer (at a lower priority) keeps within 1 s of live: run alone
def test_a_recording_cut_by_sigkill_reads_back_to_its_last_second(tmp_path):
    path = tmp_path / "killed.mcap"
    server = record_server(tmp_path, path)
    stamps: list[float] = []
    enough = threading.Event()
    try:
        ros = connect_roslibpy(server.port)

        def on_odom(msg):
            stamps.append(msg["header"]["stamp"]["secs"] + msg["header"]["stamp"]["nsecs"] / 1e9)
            if len(stamps) >= 60:
                enough.set()

        roslibpy.Topic(ros, ODOM, "nav_msgs/Odometry").subscribe(on_odom)
        assert enough.wait(20)
        # the worst case: the server and its writer process die at once (a power loss)
        pids = [server.proc.pid, *children(server.proc.pid)]
        assert len(pids) > 1, "no writer process"
        for pid in pids:
            os.kill(pid, signal.SIGKILL)
        server.proc.wait(10)
        last_live = stamps[-1]
        ros.close()
    finally:
        server.stop()
    recorded: list[float] = []
    with open(path, "rb") as f:
        reader = NonSeekingReader(f, decoder_factories=[DecoderFactory()])
        try:
            for _s, channel, _m, msg in reader.iter_decoded_messages(log_time_order=False):
                if channel.topic == ODOM:
                    recorded.append(msg.header.stamp.sec + msg.header.stamp.nanosec / 1e9)
        except McapError:
            pass  # the cut: everything before it was read
    assert recorded, "nothing readable"
    assert recorded[-1] >= last_live - 1.0, (recorded[-1], last_live)


def test_an_unwritable_recording_path_is_refused_at_start(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    done = subprocess.run(
        [sys.executable, "-m", "hitrobot_server", "--port", "0", "--tcp-port", "0",
         "--robot", "none", "--record", str(blocker / "x.mcap")],
        capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert "cannot record to" in done.stderr and "x.mcap" in done.stderr
    assert "ws://" not in done.stdout


@pytest.mark.serial  # the writer (at a lower priority) has caught up when the server dies
def test_a_killed_server_leaves_its_writer_to_finish_the_file(tmp_path):
    path = tmp_path / "finished.mcap"
    server = record_server(tmp_path, path)
    seen: list[dict] = []
    enough = threading.Event()

    def on_odom(msg):
        seen.append(msg)
        if len(seen) >= 40:
            enough.set()

    try:
        ros = connect_roslibpy(server.port)
        roslibpy.Topic(ros, ODOM, "nav_msgs/Odometry").subscribe(on_odom)
        assert enough.wait(20)
        writers = [pid for pid in children(server.proc.pid)
                   if b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes()]
        assert writers, "no writer process"
        server.proc.send_signal(signal.SIGKILL)
        server.proc.wait(10)
        ros.close()
    finally:
        server.stop()
    deadline = time.monotonic() + 15
    while any(running(pid) for pid in writers):  # bounded: 15 s
        assert time.monotonic() < deadline, "the writer did not finish"
        time.sleep(0.05)
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_summary() is not None  # finished: summary and index
        odom = [m for _s, _c, _m, m in reader.iter_decoded_messages(topics=[ODOM])]
    assert len(odom) >= 20

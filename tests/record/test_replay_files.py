"""``hitrobot-server replay`` with files it did not write whole: another robot's definitions
(served as the file defines them), a recording cut by a power loss (served as far as it goes),
decompression bombs (refused fast, in bounded memory); and its paused start."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Schema
from mcap.writer import MCAP0_MAGIC
from mcap_ros2.writer import Writer as Ros2Writer

from hitrobot_server.record.reading import RecordingError, load_recording
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import ServerProcess, connect_roslibpy
from tests.record.conftest import ODOM
from tests.record.test_replay import Collector, call

ODD_STRING = "int32 data\nstring note  # a field our std_msgs/String does not have\n"
SEP = "=" * 80
WIDGET = (f"geometry_msgs/Point where\nuint8[] blob\nacme_msgs/Part[] parts\n{SEP}\n"
          f"MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z\n{SEP}\n"
          "MSG: acme_msgs/Part\nstring name\nfloat32 weight\n")


def foreign_file(path: Path) -> Path:
    """A ROS 2 recording by another tool: a std_msgs/String with other fields, and a type of a
    package we do not have (written with mcap-ros2-support's writer)."""
    with open(path, "wb") as f:
        writer = Ros2Writer(f)
        odd = writer.register_msgdef("std_msgs/msg/String", ODD_STRING)
        widget = writer.register_msgdef("acme_msgs/msg/Widget", WIDGET)
        for i in range(5):
            t = 1_000_000_000 + i * 100_000_000
            writer.write_message("/chatter", odd, {"data": i, "note": f"n{i}"}, log_time=t,
                                 publish_time=t)
            writer.write_message("/widget", widget, {
                "where": {"x": 1.0, "y": float(i), "z": 0.0}, "blob": bytes([i, 7]),
                "parts": [{"name": "arm", "weight": 2.5}]}, log_time=t, publish_time=t)
        writer.finish()
    return path


def test_a_foreign_recording_is_served_with_its_own_definitions(tmp_path):
    server = ServerProcess("--loop", command=("replay", str(foreign_file(tmp_path / "a.mcap"))))
    try:
        ros = connect_roslibpy(server.port)
        chatter = Collector(ros, "/chatter", "std_msgs/String")
        widget = Collector(ros, "/widget", "acme_msgs/Widget")
        got = chatter.count(5)[:5]  # (it loops: more may have come)
        assert [(m["data"], m["note"]) for m in got] == [(i, f"n{i}") for i in range(5)]
        for msg in widget.count(5):
            assert msg["where"]["y"] in (0.0, 1.0, 2.0, 3.0, 4.0)
            assert msg["parts"] == [{"name": "arm", "weight": 2.5}]
        ros.close()
    finally:
        server.stop()


def test_a_recording_cut_by_a_power_loss_plays_as_far_as_it_goes(drive, tmp_path):
    path, _live = drive
    whole = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: len(whole) * 2 // 3])  # mid-chunk: no footer, no summary
    server = ServerProcess("--play", command=("replay", str(cut)))
    try:
        ros = connect_roslibpy(server.port)
        odom = Collector(ros, ODOM, "nav_msgs/Odometry")
        assert odom.count(3)
        ros.close()
    finally:
        server.stop()
    log = "".join(server.output) + server.proc.stdout.read()
    assert "ends before the MCAP footer" in log and "messages it holds" in log
    assert "cut off: served as far as it goes" in log


def test_replay_waits_paused_for_the_first_subscriber(drive):
    path, _live = drive
    server = ServerProcess(command=("replay", str(path)))
    try:
        ros = connect_roslibpy(server.port)
        state = Collector(ros, "/replay/state", "hitrobot_msgs/ReplayState")
        first = state.count(1)[0]
        assert first["paused"] and first["waiting"] and first["position"] == 0.0
        assert call(ros, "/rosapi/get_time", "rosapi/GetTime")["time"]["secs"] == int(
            first["start"])  # the server's clock is the recording's time
        odom = Collector(ros, ODOM, "nav_msgs/Odometry")
        assert odom.count(2)
        playing = state.wait_for(lambda s: not s["paused"], "playing")
        assert not playing["waiting"]
        ros.close()
    finally:
        server.stop()
    log = "".join(server.output) + server.proc.stdout.read()
    assert "paused until a client subscribes" in log and "a client subscribed to" in log


# ---------------------------------------------------------------------- bombs
ZEROS = zstandard.ZstdCompressor(level=19).compress(bytes(16 << 20))  # 16 MiB in ~500 bytes


def bomb_file(path: Path, chunks: list[tuple[bytes, int]]) -> Path:
    """An MCAP whose chunks are given as (zstd bytes, claimed uncompressed size), written record
    by record with the mcap library's records and builder (no writer makes such chunks)."""
    builder = RecordBuilder()
    records = [Header(profile="ros2", library="bomb"),
               Schema(id=1, name="std_msgs/msg/String", encoding="ros2msg", data=b"string data"),
               Channel(id=1, topic="/chatter", message_encoding="cdr", schema_id=1, metadata={})]
    records += [Chunk(compression="zstd", data=data, message_start_time=0, message_end_time=0,
                      uncompressed_crc=0, uncompressed_size=claimed) for data, claimed in chunks]
    for record in [*records, DataEnd(data_section_crc=0),
                   Footer(summary_start=0, summary_offset_start=0, summary_crc=0)]:
        record.write(builder)
    path.write_bytes(MCAP0_MAGIC + builder.end() + MCAP0_MAGIC)
    return path


# A small process runs the replay and reports its peak RSS (wait4): measured from pytest
# itself, the figure would include the child's copy of pytest's memory before its exec, which
# Linux counts in the child's ru_maxrss (hundreds of MiB late in a whole run).
MEASURE = """
import os, subprocess, sys
child = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)
_pid, status, usage = os.wait4(child.pid, 0)
sys.stderr.write(f"\\npeak-rss-kib {usage.ru_maxrss}\\n")
sys.exit(os.waitstatus_to_exitcode(status))
"""


def run_measured(path: Path, *extra: str, timeout: float = 60) -> tuple[int, str, float, int]:
    """Run ``replay`` to its exit: code, stderr, seconds, peak RSS in MiB (its own, by wait4
    in a small parent of its own)."""
    t0 = time.monotonic()
    with tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(
            [sys.executable, "-c", MEASURE, sys.executable, "-m", "hitrobot_server", "replay",
             str(path), "--port", "0", "--tcp-port", "-1", "--address", "127.0.0.1", *extra],
            stdout=subprocess.DEVNULL, stderr=err, text=True, start_new_session=True)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)
        err.seek(0)
        text = err.read()
        peak = re.search(r"peak-rss-kib (\d+)", text)
        assert peak is not None, text
        return proc.returncode, text, time.monotonic() - t0, int(peak.group(1)) >> 10


@pytest.mark.parametrize("case", ["claims_2GiB", "many_chunks", "liar"])
def test_a_decompression_bomb_is_refused_fast_in_bounded_memory(case, tmp_path):
    if case == "claims_2GiB":  # one chunk: 128 frames of 16 MiB zeros, ~60 KiB on disk
        chunks, expected = [(ZEROS * 128, 2 << 30)], "over what is left of the 1024 MiB"
    elif case == "many_chunks":  # 80 chunks of 16 MiB each: 1.25 GiB from ~40 KiB
        chunks, expected = [(ZEROS, 16 << 20)] * 80, "the file's chunks would inflate"
    else:  # claims 1000 bytes, inflates to 16 MiB
        chunks, expected = [(ZEROS, 1000)], "inflates to more than the 1000 bytes it claims"
    path = bomb_file(tmp_path / f"{case}.mcap", chunks)
    assert path.stat().st_size < 128 << 10
    code, err, seconds, rss = run_measured(path)
    assert code == 1, err
    assert expected in err, err
    assert seconds < 30, seconds  # seconds on a busy 2-core machine; refused before inflating
    print(f"{case}: refused in {seconds:.1f} s, peak RSS {rss} MiB")
    assert rss < 400, f"{rss} MiB"  # the interpreter and the server's imports: ~150 MiB


def test_a_rosbag2_bag_folder_stands_for_its_mcap(tmp_path):
    bag = tmp_path / "bag"
    bag.mkdir()
    foreign_file(bag / "bag_0.mcap")
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 9}\n")
    recording = load_recording(bag, TypeRegistry())
    assert recording.path == bag / "bag_0.mcap" and len(recording.messages) == 10
    foreign_file(bag / "bag_1.mcap")
    with pytest.raises(RecordingError, match="2 .mcap files"):
        load_recording(bag, TypeRegistry())

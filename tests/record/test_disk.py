"""The recordings on a real disk: split by time, the disk budget (the oldest go first, never the
file being written), a folder that cannot be written refused at ``/record/start``, and a
recording the disk stops (here a file size limit set on the writer process: the same failed
write as a full disk, without root) closed so that it reads back to its last complete chunk."""

from __future__ import annotations

import errno
import os
import resource
import subprocess
import sys
import time

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from hitrobot_server.bus.core import Bus
from hitrobot_server.record.files import check_writable, prune
from hitrobot_server.record.options import RecordOptions, parse_duration, parse_size
from hitrobot_server.record.recorder import Recorder
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import WsClient, until


def texts(path, topic: str = "/big") -> list[str]:
    """The ``std_msgs/String`` data of every message, read by the stock ROS 2 reader."""
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [m.data for _s, c, _m, m in reader.iter_decoded_messages() if c.topic == topic]


def make_bus() -> Bus:
    bus = Bus(TypeRegistry.default())
    bus.advertise("/big", "std_msgs/String", "node", "/node")
    return bus


def noise(n: int, seed: int) -> str:
    """Text that zstd cannot shrink much (so that files grow as written)."""
    return os.urandom(n // 2).hex()[:n] + str(seed)


def test_sizes_and_durations_of_the_flags():
    assert parse_size("500M") == 500 * 2**20 and parse_size("2G") == 2 * 2**30
    assert parse_size("1.5GiB") == int(1.5 * 2**30) and parse_size("4096") == 4096
    assert parse_duration("10m") == 600 and parse_duration("90") == 90
    assert parse_duration("2h") == 7200
    for bad in ("lots", "5X", "-1M"):
        with pytest.raises(ValueError, match="not a size"):
            parse_size(bad)
    with pytest.raises(ValueError, match="at least 1 second"):
        RecordOptions(record_split_time="0.5").check()
    with pytest.raises(ValueError, match="not a duration"):
        RecordOptions(record_split_time="soon").check()
    with pytest.raises(ValueError, match="at least 1M"):
        RecordOptions(record_max_disk="10K").check()


def test_prune_takes_the_oldest_first_and_never_the_one_kept(tmp_path):
    a, b, c, d = (tmp_path / f"{n}.mcap" for n in "abcd")
    files = [(b, 300, 2.0), (a, 300, 1.0), (d, 300, 4.0), (c, 300, 3.0)]
    assert prune(files, 650, keep={d}) == [a, b]
    assert prune(files, 250, keep={a}) == [b, c, d]  # a is kept, whatever its age
    assert prune(files, 1200, keep=set()) == []


async def test_split_by_time_follows_the_messages_log_time(tmp_path):
    bus = make_bus()
    recorder = Recorder(bus, tmp_path / "run.mcap", split_time=1.0, flush_period=0.05)
    recorder.start()
    t0 = 1_700_000_000.0
    for i, dt in enumerate((0.0, 0.5, 1.2, 2.5, 2.9)):
        bus.publish("/big", {"data": f"m{i}"}, stamp=t0 + dt)
    await recorder.stop()
    assert [p.name for p in recorder.files] == ["run.mcap", "run_1.mcap", "run_2.mcap"]
    assert [texts(p) for p in recorder.files] == [["m0", "m1"], ["m2"], ["m3", "m4"]]


async def test_a_long_recording_goes_on_in_a_new_part_after_max_chunks(tmp_path):
    """The writer's memory of an open file (its chunk index) is bounded: after max_chunks
    chunks the recording goes on in a new part, which opens with the latched messages."""
    bus = make_bus()
    bus.advertise("/latched", "std_msgs/String", "node", "/node", latch=True)
    recorder = Recorder(bus, tmp_path / "long.mcap", flush_period=0.05, max_chunks=2)
    recorder.start()
    t0 = 1_700_000_000.0
    bus.publish("/latched", {"data": "kept"}, stamp=t0)
    for i in range(6):  # a chunk each: 0.1 s of log time apart, flushed every 0.05 s
        bus.publish("/big", {"data": f"m{i}"}, stamp=t0 + 0.1 * (i + 1))
    await recorder.stop()
    assert [p.name for p in recorder.files][:2] == ["long.mcap", "long_1.mcap"]
    assert len(recorder.files) >= 3
    assert [t for p in recorder.files for t in texts(p)] == [f"m{i}" for i in range(6)]
    assert all(texts(p, "/latched") == ["kept"] for p in recorder.files)  # each part opens so


async def test_the_budget_removes_the_oldest_recordings_never_the_one_written(tmp_path):
    folder = tmp_path / "recordings"
    folder.mkdir()
    now = time.time()
    for age, name in ((300, "oldest"), (200, "older"), (100, "old")):
        path = folder / f"{name}.mcap"
        path.write_bytes(os.urandom(400_000))
        os.utime(path, (now - age, now - age))
    (folder / "notes.txt").write_bytes(os.urandom(400_000))  # not a recording: not counted
    bus = make_bus()
    budget = 1024 * 1024
    recorder = Recorder(bus, folder / "now.mcap", split_time=1.0, max_disk=budget,
                        budget_folder=folder, exclusive=True, flush_period=0.05)
    recorder.start()
    t0 = 1_700_000_000.0
    for i in range(5):  # five parts of ~300 kB each (hex: zstd halves it), one per second
        bus.publish("/big", {"data": noise(600_000, i)}, stamp=t0 + i)
        await until(lambda i=i: recorder.messages >= i + 1, f"message {i} written", 60)
    await recorder.stop()
    left = {p.name for p in folder.iterdir()}
    assert "notes.txt" in left and "oldest.mcap" not in left and "older.mcap" not in left
    assert "now_4.mcap" in left  # the last part: being written when the budget was kept
    assert "now.mcap" not in left  # its own first parts went too, oldest first
    # the budget was kept at each new part: what stays is the last part and what fitted
    # beside the part being written then
    kept = sum(p.stat().st_size for p in folder.glob("*.mcap") if p.name != "now_4.mcap")
    assert kept <= budget
    assert texts(folder / "now_4.mcap")[-1].endswith("4")


def test_check_writable_refuses_a_full_disk_or_a_taken_name(tmp_path):
    with pytest.raises(ValueError, match="KiB free on its disk"):
        check_writable(tmp_path / "big.mcap", exclusive=True, min_free=2**62)
    assert not (tmp_path / "big.mcap").exists()
    (tmp_path / "taken.mcap").write_bytes(b"x")
    with pytest.raises(ValueError, match="already exists"):
        check_writable(tmp_path / "taken.mcap", exclusive=True)
    assert (tmp_path / "taken.mcap").read_bytes() == b"x"


async def test_start_refuses_a_folder_it_cannot_write(make_server, tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    server = await make_server(record_dir=str(blocker / "recordings"))
    client = await WsClient.open(server.port)
    try:
        reply = await client.call("/record/start", {"name": "nowhere"})
        assert not reply["result"] and "cannot record to" in reply["values"], reply
        status = await client.expect(op="status", id=reply["id"])
        assert status["level"] == "error" and "cannot record to" in status["msg"]
        assert server.recording.recorder is None
        listed = await client.call("/record/list")
        assert listed["values"] == {"files": [], "sizes": []}
    finally:
        await client.close()


async def test_a_recording_the_disk_stops_is_closed_and_reads_back(make_server, tmp_path,
                                                                    caplog):
    folder = tmp_path / "recordings"
    server = await make_server(record_dir=str(folder))
    client = await WsClient.open(server.port)
    try:
        await client.send({"op": "subscribe", "topic": "/record/state"})
        await client.send({"op": "advertise", "topic": "/big", "type": "std_msgs/String"})
        assert (await client.call("/record/start", {"name": "full"}, timeout=30))["result"]
        recorder = server.recording.recorder
        await client.send({"op": "publish", "topic": "/big", "msg": {"data": "first"}})
        await until(lambda: recorder.messages >= 1 and recorder.bytes > 0,
                    "the writer's first flush", 60)
        limit = recorder.bytes + 100_000  # the disk "fills" 100 kB after what is written
        resource.prlimit(recorder._process.pid, resource.RLIMIT_FSIZE, (limit, limit))
        sent = ["first"]
        for i in range(40):  # 20 kB messages (~10 kB in the file), one chunk each
            if not recorder.alive:
                break
            sent.append(noise(20_000, i))
            written = recorder.bytes
            await client.send({"op": "publish", "topic": "/big", "msg": {"data": sent[-1]}})
            await until(lambda w=written: recorder.bytes > w or not recorder.alive,
                        "a chunk written or the recording stopped", 30)
        assert not recorder.alive, "the size limit never stopped the recording"
        await client.expect(lambda m: m.get("topic") == "/record/state"
                            and not m["msg"]["recording"], timeout=60)
        assert recorder.disk_error == errno.EFBIG
        assert f"stopped: {os.strerror(errno.EFBIG)}" in caplog.text
        again = await client.call("/record/start", {"name": "after"}, timeout=30)
        assert again["result"], again  # the recorder is free again
        assert (await client.call("/record/stop", timeout=60))["result"]
    finally:
        await client.close()
    path = folder / "full.mcap"
    assert path.stat().st_size <= limit
    read = texts(path)  # the stock reader reads it to its end without an error
    assert 5 <= len(read) < len(sent) and read == sent[: len(read)], (len(read), len(sent))


_CUT_SCRIPT = """
import random, resource, signal, sys
from pathlib import Path
from hitrobot_server.record.handoff import MSG, Item
from hitrobot_server.record.writer import write_recording
path, limit = Path(sys.argv[1]), int(sys.argv[2])
rng = random.Random(1)
items = [Item("/big", "std_msgs/msg/String", False, i, i, i, MSG,
              {"data": rng.randbytes(200_000).hex()}) for i in range(9)]
if limit:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
try:
    write_recording(path, items)
except OSError as exc:
    print(exc.errno)
"""


def test_a_footer_that_does_not_fit_gives_up_the_last_chunk(tmp_path):
    """The disk stops right after a chunk and its index, with no room for the footer: the
    index is given up (then the chunk, if need be) so that the file still ends properly."""
    whole = tmp_path / "whole.mcap"
    run = [sys.executable, "-c", _CUT_SCRIPT]
    subprocess.run([*run, str(whole), "0"], check=True, timeout=120)
    with open(whole, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    assert len(chunks) >= 3
    second = chunks[1]
    limit = second.chunk_start_offset + second.chunk_length + second.message_index_length + 20
    cut = tmp_path / "cut.mcap"
    done = subprocess.run([*run, str(cut), str(limit)], capture_output=True, text=True,
                          timeout=120)
    assert done.stdout.strip() == str(errno.EFBIG), done.stderr
    assert cut.stat().st_size <= limit
    read = texts(cut)  # the stock reader, to the end, without an error
    assert read == texts(whole)[: len(read)] and len(read) >= 3  # the first chunk at least

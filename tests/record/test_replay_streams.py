"""Replay reads a recording a chunk at a time: a recording whose messages add up to more than
``--max-inflated`` (the whole-file budget replay had before) plays to its end in memory bounded
by its chunks; a seek lands on the chunk that holds the time with the latched topics as they
were; a file cut before its summary is indexed by one scan; an honest chunk of zeros is refused
at its first block."""

from __future__ import annotations

import asyncio
import os
import struct
import time
import tracemalloc
from pathlib import Path

import pytest
from mcap.data_stream import RecordBuilder
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Schema,
    Statistics,
)
from mcap.writer import MCAP0_MAGIC, CompressionType, Writer

from hitrobot_server.bus.core import Bus
from hitrobot_server.record.player import Player
from hitrobot_server.record.reading import RecordingError, load_recording
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import until
from tests.record.test_replay_files import ZEROS, bomb_file

BLOB = 60 << 10  # bytes of each message's payload
COUNT = 400  # 400 x 60 KiB = 23.4 MiB of messages
BUDGET = 8 << 20  # --max-inflated for these tests: a third of what the messages add up to
STATE_EVERY = 50  # a latched /state every 50 messages


def cdr_blob(seq: int) -> bytes:
    """CDR of ``acme_msgs/msg/Blob`` (``uint32 seq``, ``uint8[] data``): random, so the
    chunks do not shrink when compressed."""
    return b"\x00\x01\x00\x00" + struct.pack("<II", seq, BLOB) + os.urandom(BLOB)


def cdr_string(text: str) -> bytes:
    raw = text.encode() + b"\x00"
    return b"\x00\x01\x00\x00" + struct.pack("<I", len(raw)) + raw


def big_file(path: Path) -> Path:
    """A recording written by the mcap library's writer in chunks of 256 KiB: COUNT blobs
    1 ms apart on /blob, and a latched /state saying how far it got."""
    with open(path, "wb") as f:
        writer = Writer(f, chunk_size=256 << 10, compression=CompressionType.ZSTD)
        writer.start(profile="ros2", library="test")
        blob = writer.register_schema("acme_msgs/msg/Blob", "ros2msg",
                                      b"uint32 seq\nuint8[] data\n")
        text = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data\n")
        blobs = writer.register_channel("/blob", "cdr", blob)
        state = writer.register_channel("/state", "cdr", text, {"latching": "1"})
        for i in range(COUNT):
            t = 1_000_000_000 + i * 1_000_000
            if i % STATE_EVERY == 0:
                writer.add_message(state, t, cdr_string(f"at {i}"), t)
            writer.add_message(blobs, t, cdr_blob(i), t)
        writer.finish()
    return path


@pytest.fixture(scope="module")
def big(tmp_path_factory) -> Path:
    return big_file(tmp_path_factory.mktemp("big") / "big.mcap")


async def test_a_recording_over_the_budget_plays_whole_in_memory_bounded_by_chunks(big):
    assert COUNT * BLOB > 2 * BUDGET  # the old replay refused it: it held every message
    bus = Bus(TypeRegistry.default())
    got: list[int] = []
    tracemalloc.start()
    try:
        recording = await asyncio.to_thread(load_recording, big, bus.types, BUDGET)
        bus.subscribe("/blob", "acme_msgs/Blob", "k", "/k", lambda m: got.append(m.msg["seq"]))
        assert len(recording.messages) == COUNT + COUNT // STATE_EVERY
        assert abs(recording.duration - (COUNT - 1) / 1000) < 1e-9
        player = Player(bus, recording, speed=100.0, play=True)
        await player.start()
        try:
            await until(lambda: len(got) == COUNT, "every blob", 30)
        finally:
            await player.stop()
        _now, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
        recording.close()
    assert got == list(range(COUNT))
    print(f"{COUNT * BLOB >> 20} MiB of messages replayed; peak {peak / 2**20:.1f} MiB")
    assert peak < BUDGET, f"{peak} bytes held"  # a few chunks of 256 KiB, not 23 MiB


async def test_a_seek_reads_from_the_chunk_that_holds_the_time(big):
    bus = Bus(TypeRegistry.default())
    blobs: list[int] = []
    states: list[str] = []
    recording = await asyncio.to_thread(load_recording, big, bus.types, BUDGET)
    bus.subscribe("/blob", "acme_msgs/Blob", "k", "/k", lambda m: blobs.append(m.msg["seq"]))
    bus.subscribe("/state", "std_msgs/String", "s", "/s", lambda m: states.append(m.msg["data"]))
    player = Player(bus, recording, speed=1.0)  # paused
    await player.start()
    try:
        reply = await bus.call_service("/replay/seek", {"position": 0.3205})
        assert reply["success"] and states[-1] == "at 300"  # the latched one before 0.3205 s
        assert not blobs
        await bus.call_service("/replay/resume", {})
        await until(lambda: len(blobs) >= 3, "blobs after the seek", 10)
        assert blobs[:3] == [321, 322, 323]
    finally:
        await player.stop()
        recording.close()


def test_a_file_cut_before_its_summary_is_indexed_by_one_scan(big, tmp_path):
    whole = big.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: len(whole) // 2])
    recording = load_recording(cut, TypeRegistry(), BUDGET)
    try:
        assert not recording.complete
        seqs = [struct.unpack_from("<I", data, 4)[0] for channel, _t, data in
                recording.messages if recording.tracks[channel].topic == "/blob"]
        assert seqs == list(range(len(seqs))) and COUNT // 3 < len(seqs) < COUNT // 2 + 5
    finally:
        recording.close()


def test_an_honest_chunk_of_zeros_is_refused_at_its_first_block(tmp_path):
    path = bomb_file(tmp_path / "zeros.mcap", [(ZEROS * 64, 1 << 30)])  # 1 GiB, as it claims
    types = TypeRegistry()
    tracemalloc.start()
    t0 = time.monotonic()
    try:
        with pytest.raises(RecordingError, match="does not begin with a record"):
            load_recording(path, types)
        seconds = time.monotonic() - t0
        _now, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    print(f"1 GiB of zeros refused in {seconds:.2f} s, peak {peak >> 20} MiB")
    assert peak < 100 << 20 and seconds < 10


def indexed_bomb(path: Path) -> Path:
    """A 1 GiB chunk of zeros that the file's summary indexes as a chunk of one message."""
    builder = RecordBuilder()
    schema = Schema(id=1, name="std_msgs/msg/String", encoding="ros2msg", data=b"string data")
    channel = Channel(id=1, topic="/chatter", message_encoding="cdr", schema_id=1, metadata={})
    for record in (Header(profile="ros2", library="bomb"), schema, channel):
        record.write(builder)
    at = len(MCAP0_MAGIC) + builder.count
    data = ZEROS * 64
    Chunk(compression="zstd", data=data, message_start_time=1, message_end_time=1,
          uncompressed_crc=0, uncompressed_size=1 << 30).write(builder)
    length = len(MCAP0_MAGIC) + builder.count - at
    DataEnd(data_section_crc=0).write(builder)
    summary = len(MCAP0_MAGIC) + builder.count
    for record in (schema, channel, ChunkIndex(
            message_start_time=1, message_end_time=1, chunk_start_offset=at,
            chunk_length=length, message_index_offsets={1: at + length},
            message_index_length=0, compression="zstd", compressed_size=len(data),
            uncompressed_size=1 << 30), Statistics(
            message_count=1, schema_count=1, channel_count=1, attachment_count=0,
            metadata_count=0, chunk_count=1, message_start_time=1, message_end_time=1,
            channel_message_counts={1: 1})):
        record.write(builder)
    Footer(summary_start=summary, summary_offset_start=0, summary_crc=0).write(builder)
    path.write_bytes(MCAP0_MAGIC + builder.end() + MCAP0_MAGIC)
    return path


def test_a_chunk_of_zeros_the_summary_indexes_is_refused_at_open(tmp_path):
    path = indexed_bomb(tmp_path / "indexed.mcap")
    with pytest.raises(RecordingError, match="does not begin with a record"):
        load_recording(path, TypeRegistry())

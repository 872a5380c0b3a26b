"""The recorder on a bus, without sockets: topic filter, bounded queue, split files, latched
messages first, the audit entries of client ops."""

from __future__ import annotations

import os

import numpy as np
import orjson
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.topics import Message, Origin
from hitrobot_server.record.handoff import MSG, Item
from hitrobot_server.record.profile import AUDIT_TOPIC
from hitrobot_server.record.recorder import Recorder, split_name
from hitrobot_server.record.writer import write_recording
from hitrobot_server.session.rosbridge.encodings import seeded
from hitrobot_server.types.registry import TypeRegistry
from tests.helpers import until


def decoded(path):
    out = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _s, channel, _m, msg in reader.iter_decoded_messages():
            out.append((channel.topic, msg))
    return out


def make_bus() -> Bus:
    bus = Bus(TypeRegistry.default())
    bus.advertise("/keep", "std_msgs/String", "node", "/node")
    bus.advertise("/skip", "std_msgs/String", "node", "/node")
    bus.advertise("/latched", "std_msgs/String", "node", "/node", latch=True)
    return bus


async def test_topic_filter_and_latched_messages_first(tmp_path):
    bus = make_bus()
    bus.advertise("/latched_elsewhere", "std_msgs/String", "node", "/node", latch=True)
    bus.publish("/latched", {"data": "before"})
    bus.publish("/latched_elsewhere", {"data": "not asked for"})
    recorder = Recorder(bus, tmp_path / "r.mcap", topics="/keep*,/latched")
    recorder.start()
    bus.publish("/keep", {"data": "a"})
    bus.publish("/skip", {"data": "b"})
    await recorder.stop()
    assert [(t, m.data) for t, m in decoded(tmp_path / "r.mcap")] == [
        ("/latched", "before"), ("/keep", "a")]
    assert bus.taps == []


async def test_a_full_queue_drops_and_counts(tmp_path, caplog):
    bus = make_bus()
    recorder = Recorder(bus, tmp_path / "r.mcap", max_queued_bytes=0)
    recorder.start()
    for i in range(10):
        bus.publish("/keep", {"data": str(i)})
    await recorder.stop()
    assert recorder.dropped == 10 and recorder.messages == 0
    assert "cannot keep up: 1 messages dropped" in caplog.text


async def test_split_files_each_open_with_the_latched_messages(tmp_path):
    bus = make_bus()
    bus.publish("/latched", {"data": "map"})
    recorder = Recorder(bus, tmp_path / "run.mcap", split_size=1, flush_period=0.01)
    recorder.start()
    bus.publish("/keep", {"data": "one"})
    await until(lambda: len(recorder.files) >= 2, "a second file", 30)
    bus.publish("/keep", {"data": "two"})
    await until(lambda: recorder.messages >= 4, "the second message written", 30)
    await recorder.stop()
    assert recorder.files[:2] == [tmp_path / "run.mcap", tmp_path / "run_1.mcap"]
    assert decoded(recorder.files[0])[0][1].data == "map"
    parts = [decoded(f) for f in recorder.files]
    assert all(p and p[0] == ("/latched", p[0][1]) and p[0][1].data == "map" for p in parts)
    assert [m.data for p in parts for t, m in p if t == "/keep"] == ["one", "two"]
    assert split_name(tmp_path / "a.mcap", 3) == tmp_path / "a_3.mcap"


async def test_client_ops_that_reach_a_node_are_audited(tmp_path):
    bus = make_bus()
    bus.subscribe("/keep", None, "sub", "/some_node", lambda m: None)
    bus.subscribe("/skip", None, "sub", "/hitrobot_client_9", lambda m: None)
    recorder = Recorder(bus, tmp_path / "r.mcap")
    recorder.start()
    client = Origin("/hitrobot_client_1", None, peer="127.0.0.1")
    bus.publish("/keep", {"data": "to a node"}, origin=client)
    bus.publish("/skip", {"data": "to a client"}, origin=client)
    bus.publish("/keep", {"data": "from a node"})
    await recorder.stop()
    entries = [m for t, m in decoded(tmp_path / "r.mcap") if t == AUDIT_TOPIC]
    assert [(e.op, e.name, e.client, e.address) for e in entries] == [
        ("publish", "/keep", "/hitrobot_client_1", "127.0.0.1")]


async def test_service_calls_and_goals_of_clients_are_audited(tmp_path):
    bus = make_bus()

    async def serve(request):
        return {}

    async def run(handle):
        return None

    bus.advertise_service("/robot/do", "std_srvs/Trigger", "node", "/robot", serve)
    bus.advertise_service("/rosapi/topics", "std_srvs/Trigger", "rosapi", "/rosapi", serve)
    bus.advertise_service("/client/srv", "std_srvs/Trigger", "c", "/hitrobot_client_2", serve,
                          client=True)
    bus.advertise_action("/robot/go", "nav2_msgs/FollowPath", "node", "/robot", run)
    recorder = Recorder(bus, tmp_path / "r.mcap")
    recorder.start()
    client = Origin("/hitrobot_client_1", "admin", peer="10.0.0.7")
    for op, name in (("call_service", "/robot/do"), ("call_service", "/rosapi/topics"),
                     ("call_service", "/client/srv"), ("send_action_goal", "/robot/go"),
                     ("send_action_goal", "/missing")):
        bus.client_called(op, name, client)
    await recorder.stop()
    entries = [m for t, m in decoded(tmp_path / "r.mcap") if t == AUDIT_TOPIC]
    assert [(e.op, e.name, e.type, e.auth_level, e.address) for e in entries] == [
        ("call_service", "/robot/do", "std_srvs/srv/Trigger", "admin", "10.0.0.7"),
        ("send_action_goal", "/robot/go", "nav2_msgs/action/FollowPath", "admin", "10.0.0.7")]


def test_write_recording_writes_encoded_messages_into_a_new_file_only(tmp_path):
    """The black box's way in: already-made messages, in one go."""
    items = [Item("/keep", "std_msgs/msg/String", False, i, i, i, MSG, {"data": f"m{i}"})
             for i in range(3)]
    path = tmp_path / "snap.mcap"
    assert write_recording(path, items, metadata={"cause": "test"}) == 3
    assert [m.data for _t, m in decoded(path)] == ["m0", "m1", "m2"]
    with open(path, "rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert meta["hitrobot-recording"] == {"cause": "test"}
    with pytest.raises(FileExistsError):
        write_recording(path, items)
    os.symlink(tmp_path / "outside.mcap", tmp_path / "link.mcap")
    with pytest.raises(FileExistsError):
        write_recording(tmp_path / "link.mcap", items)
    assert not (tmp_path / "outside.mcap").exists()


def client_publish(bus: Bus, topic: str, msg: dict) -> Message:
    """As a rosbridge client's publish reaches the bus: with its own JSON op (the seed)."""
    op = orjson.dumps({"op": "publish", "topic": topic, "msg": msg})
    return bus.publish(topic, msg, seed=seeded(len(op), topic, op))


async def test_a_client_publish_goes_to_the_writer_as_its_own_json(tmp_path):
    """While the writer keeps up, the tap encodes nothing: a client's LaserScan goes as the
    client's JSON, a node's as the message, and the writer makes the CDR of both."""
    bus = make_bus()
    bus.advertise("/scan", "sensor_msgs/LaserScan", "node", "/node")
    bus.advertise("/path", "nav_msgs/Path", "node", "/node")
    recorder = Recorder(bus, tmp_path / "r.mcap")
    recorder.start()
    scan = client_publish(bus, "/scan", {"ranges": [1.5, None, 3.0], "range_max": 30.0})
    path = client_publish(bus, "/path", {"poses": [{"pose": {"position": {"x": float(i)}}}
                                                   for i in range(3)]})
    node_scan = bus.publish("/scan", {"ranges": [2.0]})
    await recorder.stop()
    assert scan.cdr_bytes is None and path.cdr_bytes is None and node_scan.cdr_bytes is None
    got = decoded(tmp_path / "r.mcap")
    ranges = list(got[0][1].ranges)
    assert ranges[0] == 1.5 and np.isnan(ranges[1]) and ranges[2] == 3.0
    assert got[0][1].range_max == 30.0
    assert list(got[2][1].ranges) == [2.0]
    assert [p.pose.position.x for p in got[1][1].poses] == [0.0, 1.0, 2.0]


def test_a_writer_behind_gets_flat_messages_encoded_on_the_loop(tmp_path):
    """Once more than an eighth of the queue bound waits for the writer (here it is stopped),
    the tap encodes a client's flat message itself (the writer's cheaper kind, and the bytes
    shared: ``cdr_bytes``, which Zenoh and Foxglove take too); a Path (a message per pose)
    is still left to the writer. Everything reads back the same."""
    import asyncio
    import multiprocessing
    import signal

    bus = make_bus()
    bus.advertise("/scan", "sensor_msgs/LaserScan", "node", "/node")
    bus.advertise("/path", "nav_msgs/Path", "node", "/node")
    recorder = Recorder(bus, tmp_path / "r.mcap", max_queued_bytes=64 * 1024)
    recorder.start()  # no loop here: each message is handed over at once
    (writer,) = multiprocessing.active_children()
    os.kill(writer.pid, signal.SIGSTOP)
    try:
        scans = [client_publish(bus, "/scan", {"ranges": [float(i)] * 100, "range_max": 9.0})
                 for i in range(30)]
        path = client_publish(bus, "/path", {"poses": [{"pose": {"position": {"x": 1.0}}}]})
    finally:
        os.kill(writer.pid, signal.SIGCONT)
    asyncio.run(recorder.stop())
    encoded = [s.cdr_bytes is not None for s in scans]
    assert not encoded[0] and encoded[-1], encoded
    assert encoded == sorted(encoded), "once behind, every later one (the writer never took)"
    assert path.cdr_bytes is None
    with open(tmp_path / "r.mcap", "rb") as f:
        raw = [m.data for _s, c, m in make_reader(f).iter_messages() if c.topic == "/scan"]
    assert [raw[i] for i, e in enumerate(encoded) if e] == [s.cdr_bytes for s in scans
                                                           if s.cdr_bytes is not None]
    got = [m for t, m in decoded(tmp_path / "r.mcap") if t == "/scan"]
    assert [list(m.ranges) for m in got] == [[float(i)] * 100 for i in range(30)]
    assert recorder.dropped == 0


async def test_a_topic_back_with_another_type_does_not_take_another_topics_number(tmp_path):
    """Each topic (and each new type of one) gets a number of its own in the hand-off: a
    topic that came back with another type and a topic seen after it stay apart."""
    bus = make_bus()
    recorder = Recorder(bus, tmp_path / "r.mcap")
    recorder.start()
    bus.publish("/keep", {"data": "a"})
    bus.publish("/skip", {"data": "b"})
    del bus.topics["/keep"]  # expired (no publisher, no subscriber), then advertised anew
    bus.advertise("/keep", "std_msgs/Int32", "node", "/node")
    bus.publish("/keep", {"data": 5})
    bus.advertise("/new", "std_msgs/String", "node", "/node")
    bus.publish("/new", {"data": "c"})
    bus.publish("/keep", {"data": 6})
    await recorder.stop()
    with open(tmp_path / "r.mcap", "rb") as f:
        topics = [c.topic for _s, c, _m in make_reader(f).iter_messages()]
    assert topics == ["/keep", "/skip", "/keep", "/new", "/keep"]
    assert [m.data for t, m in decoded(tmp_path / "r.mcap") if t == "/new"] == ["c"]


async def test_the_audit_keeps_its_own_number_beside_a_topic_of_that_name(tmp_path):
    """A client may publish on a topic named like the audit channel; with that topic filtered
    out, the audit entries are still written (the filter never applied to them)."""
    bus = make_bus()

    async def serve(request):
        return {}

    bus.advertise_service("/robot/do", "std_srvs/Trigger", "node", "/robot", serve)
    bus.advertise(AUDIT_TOPIC, "std_msgs/String", "c", "/hitrobot_client_1")
    recorder = Recorder(bus, tmp_path / "r.mcap", topics="/keep")
    recorder.start()
    bus.publish(AUDIT_TOPIC, {"data": "not an audit entry"})
    bus.client_called("call_service", "/robot/do",
                      Origin("/hitrobot_client_1", "admin", peer="10.0.0.7"))
    await recorder.stop()
    entries = [m for t, m in decoded(tmp_path / "r.mcap") if t == AUDIT_TOPIC]
    assert [(e.op, e.name) for e in entries] == [("call_service", "/robot/do")]

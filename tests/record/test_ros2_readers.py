"""A recording is a pure ROS 2 recording: a session (publishes, a service call, an action goal,
the audit entries they leave) read whole by the stock ROS 2 readers — ``mcap`` with
``mcap-ros2-support``'s decoder, and ``rosbags``' rosbag2 reader — not by our decoder."""

from __future__ import annotations

import math
from collections import Counter

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from hitrobot_server.record.profile import AUDIT_TOPIC
from tests.helpers import WsClient

SCAN = {"header": {"frame_id": "laser"}, "angle_min": -1.0, "angle_max": 1.0,
        "angle_increment": 1.0, "range_min": 0.1, "range_max": 10.0,
        "ranges": [1.5, None, 2.5], "intensities": []}


def stock_read(path):
    """Every message of the file through mcap-ros2-support's decoder (no topic filter)."""
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        decoded = [(c.topic, msg) for _s, c, _m, msg in reader.iter_decoded_messages()]
    return summary, decoded


def rosbags_read(path):
    """Every message through rosbags' rosbag2 reader, each type from the file's own
    definitions."""
    store = get_typestore(Stores.EMPTY)
    out = []
    with Reader(path) as reader:
        for conn in reader.connections:
            store.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        for conn, _t, raw in reader.messages():
            out.append((conn.topic, store.deserialize_cdr(raw, conn.msgtype)))
    return out


async def record_a_session(client: WsClient) -> None:
    assert (await client.call("/record/start", {"name": "session"}))["values"]["success"]
    await client.send({"op": "advertise", "topic": "/chatter", "type": "std_msgs/String"})
    await client.send({"op": "advertise", "topic": "/scan_in", "type": "sensor_msgs/LaserScan"})
    for i in range(3):
        await client.send({"op": "publish", "topic": "/chatter", "msg": {"data": f"hi {i}"}})
    await client.send({"op": "publish", "topic": "/scan_in", "msg": SCAN})
    added = await client.call("/add_two_ints", {"a": 2, "b": 3})
    assert added["values"] == {"sum": 5}
    await client.send({"op": "send_action_goal", "id": "fib", "action": "/fibonacci",
                       "action_type": "example_interfaces/action/Fibonacci",
                       "args": {"order": 4}})
    result = await client.expect(op="action_result", id="fib", timeout=20)
    assert result["result"] is True, result
    # the writer process may still be starting (spawn) on a busy machine
    assert (await client.call("/record/stop", timeout=60))["values"]["success"]


async def test_a_session_reads_whole_with_the_stock_ros2_readers(make_server, tmp_path):
    folder = tmp_path / "recordings"
    server = await make_server(record_dir=str(folder), demo_services=True)
    client = await WsClient.open(server.port)
    try:
        await record_a_session(client)
    finally:
        await client.close()
    path = folder / "session.mcap"

    summary, decoded = stock_read(path)
    assert len(decoded) == summary.statistics.message_count > 0
    for channel in summary.channels.values():
        schema = summary.schemas[channel.schema_id]
        assert (schema.encoding, channel.message_encoding) == ("ros2msg", "cdr"), channel.topic
    topics = Counter(t for t, _m in decoded)
    assert topics["/chatter"] == 3 and topics["/scan_in"] == 1
    assert [m.data for t, m in decoded if t == "/chatter"] == ["hi 0", "hi 1", "hi 2"]
    scan = next(m for t, m in decoded if t == "/scan_in")
    assert scan.ranges[0] == 1.5 and math.isnan(scan.ranges[1])  # a JSON null is NaN
    audit = [m for t, m in decoded if t == AUDIT_TOPIC]
    assert {(e.op, e.name, e.type) for e in audit} == {
        ("call_service", "/add_two_ints", "example_interfaces/srv/AddTwoInts"),
        ("send_action_goal", "/fibonacci", "example_interfaces/action/Fibonacci"),
        ("call_service", "/record/stop", "std_srvs/srv/Trigger")}  # the stop itself too
    assert all(e.client.startswith("/hitrobot_client_") and e.address.startswith("127.0.0.1")
               and e.stamp.sec > 0 for e in audit)
    schema = next(s for s in summary.schemas.values() if s.name == "hitrobot_msgs/msg/AuditEntry")
    assert b"string auth_level" in schema.data

    read = rosbags_read(path)
    assert Counter(t for t, _m in read) == topics
    assert [m.data for t, m in read if t == "/chatter"] == ["hi 0", "hi 1", "hi 2"]
    assert {m.name for t, m in read if t == AUDIT_TOPIC} == {"/add_two_ints", "/fibonacci",
                                                             "/record/stop"}

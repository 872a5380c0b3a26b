"""A server joined to another by Zenoh records what reaches it from there (the CDR as it
arrived), read back with mcap-ros2-support."""

from __future__ import annotations

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from tests.bus.test_zenoh_scale_out import free_port, sees_subscriber, until, zenoh_server
from tests.helpers import WsClient


async def test_messages_from_another_server_are_recorded(tmp_path):
    port = free_port()
    a = zenoh_server(listen=port)
    b = zenoh_server(connect=port, extra=("--record-dir", str(tmp_path)))
    pub = sub = None
    try:
        pub = await WsClient.open(a.port)
        sub = await WsClient.open(b.port)
        await sub.send({"op": "subscribe", "topic": "/chatter", "type": "std_msgs/String"})
        await pub.send({"op": "advertise", "topic": "/chatter", "type": "std_msgs/String"})
        await until(lambda: sees_subscriber(pub, "/chatter"), 20, "B's subscriber seen on A")
        started = await sub.call("/record/start", {"name": "remote"})
        assert started["values"]["success"], started
        for i in range(5):
            await pub.send({"op": "publish", "topic": "/chatter", "msg": {"data": f"from A {i}"}})
        for i in range(5):
            got = await sub.expect(op="publish", topic="/chatter", timeout=10)
            assert got["msg"]["data"] == f"from A {i}"
        assert (await sub.call("/record/stop", timeout=60))["values"]["success"]
    finally:
        for client in (pub, sub):
            if client is not None:
                await client.close()
        b.stop()
        a.stop()
    with open(tmp_path / "remote.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        texts = [m.data for _s, _c, _m, m in reader.iter_decoded_messages(topics=["/chatter"])]
    assert texts == [f"from A {i}" for i in range(5)]

"""Channels: serverInfo, one channel per bus topic advertised and withdrawn as the bus changes,
``--topics-glob`` hiding channels, and the table of channels shared by every session
(``channels.py``, ``shared.py``)."""

from __future__ import annotations

from hitrobot_server.nodes.base import Node
from tests.session.foxglove.client import FoxClient


async def test_server_info_then_a_channel_per_topic(hub):
    node = Node(hub.bus, "/pub")
    node.advertise("/fg/chatter", "std_msgs/String")
    fox = FoxClient(hub)
    info = (await fox.frames())[0]
    assert info["op"] == "serverInfo" and "clientPublish" in info["capabilities"]
    adv = await fox.op("advertise")
    topics = {c["topic"]: c for c in adv["channels"]}
    assert set(hub.bus.topics) == set(topics)
    assert topics["/fg/chatter"]["schemaName"] == "std_msgs/msg/String"
    assert topics["/fg/chatter"]["schema"] == "string data\n"
    node.advertise("/fg/later", "std_msgs/Int32")
    adv = await fox.op("advertise")
    assert [c["topic"] for c in adv["channels"]] == ["/fg/later"]
    node.close()
    gone = await fox.op("unadvertise")
    assert topics["/fg/chatter"]["id"] in gone["channelIds"]


async def test_topics_glob_hides_channels_and_refuses_publishing(make_hub):
    hub = await make_hub(topics_glob="/fg/*")
    Node(hub.bus, "/pub").advertise("/fg/ok", "std_msgs/String")
    Node(hub.bus, "/pub2").advertise("/secret", "std_msgs/String")
    fox = FoxClient(hub, topics_glob="/fg/*")
    adv = await fox.op("advertise")
    assert [c["topic"] for c in adv["channels"]] == ["/fg/ok"]
    fox.send({"op": "advertise", "channels": [{"id": 1, "topic": "/secret", "encoding": "cdr",
                                               "schemaName": "std_msgs/msg/String"}]})
    assert "--topics-glob" in (await fox.error())["message"]
    assert list(hub.bus.topic("/secret").publishers.values()) == ["/pub2"]


async def test_forgotten_channels_of_topics_gone_keep_the_table_bounded(hub, monkeypatch):
    monkeypatch.setattr("hitrobot_server.session.foxglove.shared.MAX_REMEMBERED", 3)
    node = Node(hub.bus, "/churn")
    fox = FoxClient(hub)
    for i in range(6):
        node.advertise(f"/fg/churn{i}", "std_msgs/String")
        fox.shared.channel(hub.bus.topic(f"/fg/churn{i}"))
        hub.bus.unadvertise(f"/fg/churn{i}", node)
        hub.bus._expire(hub.bus.topic(f"/fg/churn{i}"))
    fox.shared.prune()
    names = {name for name, _type in fox.shared._channels}
    assert names and names <= set(hub.bus.topics)
    assert not any(name.startswith("/fg/churn") for name in names)

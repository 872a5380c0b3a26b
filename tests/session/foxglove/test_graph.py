"""The connection graph follows the bus (``graph.py``)."""

from __future__ import annotations

from hitrobot_server.nodes.base import Node
from tests.session.foxglove.client import FoxClient


async def test_connection_graph_follows_the_bus(hub):
    fox = FoxClient(hub)
    fox.send({"op": "subscribeConnectionGraph"})
    first = await fox.op("connectionGraphUpdate")
    assert any(s["name"] == "/rosapi/topics" for s in first["advertisedServices"])
    node = Node(hub.bus, "/grapher")
    node.advertise("/fg/graph", "std_msgs/String")
    update = await fox.op("connectionGraphUpdate")
    assert {"name": "/fg/graph", "publisherIds": ["/grapher"]} in update["publishedTopics"]

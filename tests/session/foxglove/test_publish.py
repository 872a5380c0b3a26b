"""Client publishing: a client's channel publishes on the bus, bad CDR and wrong types refused
(``publish.py``)."""

from __future__ import annotations

import struct

from hitrobot_server.nodes.base import Node
from tests.session.foxglove.client import FoxClient


async def test_client_publish_reaches_the_bus_and_bad_cdr_is_refused(hub):
    got = []
    Node(hub.bus, "/sub").subscribe("/fg/cmd", "geometry_msgs/Twist", lambda m: got.append(m.msg))
    fox = FoxClient(hub)
    fox.send({"op": "advertise", "channels": [{"id": 7, "topic": "/fg/cmd", "encoding": "cdr",
                                               "schemaName": "geometry_msgs/msg/Twist"}]})
    twist = {"linear": {"x": 0.5, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 1.0}}
    cdr = fox.codec.encode(twist, hub.bus.types.msg("geometry_msgs/Twist"))
    fox.send(struct.pack("<BI", 1, 7) + cdr)
    assert got == [twist]
    fox.send(struct.pack("<BI", 1, 7) + cdr[:9])
    err = await fox.error()
    assert "does not match geometry_msgs/msg/Twist" in err["message"]
    assert len(got) == 1
    fox.send({"op": "advertise", "channels": [{"id": 8, "topic": "/fg/cmd", "encoding": "cdr",
                                               "schemaName": "std_msgs/msg/String"}]})
    assert "already has type" in (await fox.error())["message"]
    fox.send({"op": "advertise", "channels": [{"id": 9, "topic": "/fg/x", "encoding": "json",
                                               "schemaName": "std_msgs/msg/String"}]})
    assert "'encoding'" in (await fox.error())["message"]
    fox.send({"op": "unadvertise", "channelIds": [7]})
    assert fox.session.node not in hub.bus.topic("/fg/cmd").publishers.values()

"""The one graph query: this bus and the processes its link joins, merged."""

from __future__ import annotations

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.graph import GraphView, whole_graph
from hitrobot_server.bus.link import RemoteGraph
from hitrobot_server.bus.zenoh.keys import PUBLISHER, SERVICE, qos_key, token
from hitrobot_server.bus.zenoh.link import ZenohLink
from hitrobot_server.types.registry import TypeRegistry


class FakeLink:
    def __init__(self, graph: RemoteGraph):
        self._graph = graph

    def graph(self) -> RemoteGraph:
        return self._graph

    def changed(self, kind: str, name: str) -> None:
        pass


async def test_local_and_remote_are_one_graph():
    bus = Bus(TypeRegistry.default(), unregister_timeout=0)
    bus.register_node("/here")
    bus.advertise("/chatter", "std_msgs/String", "pub", "/here")
    bus.subscribe("/chatter", None, "sub", "/here_sub", lambda m: None)

    async def serve(req: dict) -> dict:
        return {}

    bus.advertise_service("/here/srv", "std_srvs/Trigger", "svc", "/here", serve)
    bus.link = FakeLink(RemoteGraph(
        topics={"/chatter": "other/msg/Kind", "/far": "std_msgs/msg/Int32"},
        publishers={"/chatter": {"/there"}, "/far": {"/there"}},
        subscribers={"/far": {"/there_sub"}},
        services={"/there/srv": ("std_srvs/srv/Trigger", "/there")},
        actions={"/there/act": ("nav2_msgs/action/NavigateToPose", "/there")},
        nodes={"/there"},
    ))
    graph = whole_graph(bus)
    assert {"/here", "/there"} <= graph.nodes
    assert graph.topics["/chatter"] == bus.topic("/chatter").type_name  # this process wins
    assert graph.topics["/far"] == "std_msgs/msg/Int32"
    assert graph.publishers["/chatter"] == {"/here", "/there"}
    assert graph.subscribers["/chatter"] == {"/here_sub"}
    assert graph.subscribers["/far"] == {"/there_sub"}
    assert graph.services["/here/srv"] == (bus.service("/here/srv").type_name, "/here")
    assert graph.services["/there/srv"] == ("std_srvs/srv/Trigger", "/there")
    assert graph.actions == {"/there/act": ("nav2_msgs/action/NavigateToPose", "/there")}
    bus.link = None
    assert "/there" not in whole_graph(bus).nodes


async def test_the_graph_view_hears_local_and_link_changes_as_one():
    """A GraphView names topics and services on either side (this process's type first) and
    raises one change event for a local change and for another process's entity (as the
    Zenoh link reports its tokens), until it is unwatched."""
    bus = Bus(TypeRegistry.default(), unregister_timeout=0)
    link = ZenohLink(bus)  # never started: no session, no network
    link.peer.zid = "a" * 32
    bus.link = link
    view = GraphView(bus)
    heard: list[tuple[str, str]] = []
    view.watch(lambda kind, name: heard.append((kind, name)))

    def announce(alive: bool, kind: str, eid: int, name: str, type_name: str) -> None:
        link.remote._token_event(token(0, "b" * 32, 0, eid, kind, "/there", name,
                                       type_name=type_name, type_hash="RIHS01_00",
                                       qos=qos_key()), alive)

    bus.advertise("/here", "std_msgs/String", "pub", "/me")
    announce(True, PUBLISHER, 1, "/scan", "sensor_msgs/msg/LaserScan")
    announce(True, PUBLISHER, 2, "/odd", "no_such/msg/Kind")
    announce(True, SERVICE, 3, "/there/trigger", "std_srvs/srv/Trigger")
    assert heard == [("topic", "/here"), ("topic", "/scan"), ("topic", "/odd"),
                     ("service", "/there/trigger")]
    assert {"/here", "/scan", "/odd"} <= view.topic_names()
    assert view.topic_type("/here") == bus.topic("/here").type_name
    assert view.topic_type("/scan") == TypeRegistry.default().msg("sensor_msgs/LaserScan").name
    assert view.topic_type("/odd") is None  # no schema here: not offered
    assert view.topic_type("/nowhere") is None
    assert view.service_type("/there/trigger") == TypeRegistry.default().srv(
        "std_srvs/Trigger").name

    announce(False, PUBLISHER, 1, "/scan", "sensor_msgs/msg/LaserScan")
    assert heard[-1] == ("topic", "/scan") and "/scan" not in view.topic_names()
    watcher = bus.remote_watchers[0]
    view.unwatch(heard.append)  # not a watcher: nothing changes
    assert bus.remote_watchers == [watcher]
    view.unwatch(watcher)
    assert watcher not in bus.watchers and watcher not in bus.remote_watchers
    bus.link = None

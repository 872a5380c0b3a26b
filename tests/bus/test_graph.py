"""The one graph query: this bus and the processes its link joins, merged."""

from __future__ import annotations

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.graph import whole_graph
from hitrobot_server.bus.link import RemoteGraph
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

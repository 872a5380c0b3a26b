"""The Zenoh link's composition, without a network: it offers what the bus expects of a link
(:class:`BusLink`), and the other processes' tokens become rosapi's remote graph."""

from __future__ import annotations

import inspect

from hitrobot_server.bus.core import Bus
from hitrobot_server.bus.link import BusLink
from hitrobot_server.bus.zenoh.keys import NODE, PUBLISHER, SERVICE, SUBSCRIBER, qos_key, token
from hitrobot_server.bus.zenoh.link import ZenohLink
from hitrobot_server.types.registry import TypeRegistry

OTHER = "b" * 32


def test_zenoh_link_implements_bus_link():
    wanted = {name: fn for name, fn in vars(BusLink).items()
              if inspect.isfunction(fn) and not name.startswith("_")}
    assert set(wanted) == {"changed", "published", "remote_type", "remote_service",
                           "remote_action", "graph", "group"}
    for name, fn in wanted.items():
        mine = getattr(ZenohLink, name)
        assert list(inspect.signature(mine).parameters) == list(
            inspect.signature(fn).parameters), name


def announce(link: ZenohLink, alive: bool, kind: str, eid: int, name: str = "",
             node: str = "/talker", zid: str = OTHER, **endpoint: str) -> None:
    link.remote._token_event(token(0, zid, 0, eid, kind, node, name, **endpoint), alive)


def test_other_processes_tokens_make_the_remote_graph():
    link = ZenohLink(Bus(TypeRegistry.default()))  # never started: no session, no network
    link.peer.zid = "a" * 32
    chatter = {"type_name": "std_msgs/msg/String", "type_hash": "RIHS01_00", "qos": qos_key()}
    announce(link, True, NODE, 0)
    announce(link, True, PUBLISHER, 1, "/chatter", **chatter)
    announce(link, True, SUBSCRIBER, 2, "/chatter", node="/listener", **chatter)
    announce(link, True, SERVICE, 3, "/fib/_action/send_goal",
             type_name="example_interfaces/action/Fibonacci_SendGoal", type_hash="RIHS01_00",
             qos=qos_key())
    announce(link, True, PUBLISHER, 4, "/mine", zid=link.peer.zid, **chatter)  # our own: ignored

    graph = link.graph()
    assert graph.nodes == {"/talker", "/listener"}
    assert graph.topics["/chatter"] == "std_msgs/msg/String" and "/mine" not in graph.topics
    assert graph.publishers["/chatter"] == {"/talker"}
    assert graph.subscribers["/chatter"] == {"/listener"}
    assert graph.actions == {"/fib": ("example_interfaces/action/Fibonacci", "/talker")}
    assert "/fib/_action/feedback" in graph.topics  # listed as a local action's are
    assert link.remote_type("/chatter") == "std_msgs/msg/String"
    assert link.topics._remote_subs == {"/chatter": 1}

    announce(link, False, SUBSCRIBER, 2, "/chatter", node="/listener", **chatter)
    assert link.graph().subscribers == {} and link.topics._remote_subs == {}
    assert link.graph().nodes == {"/talker"}

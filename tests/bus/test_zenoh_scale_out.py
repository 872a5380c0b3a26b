"""Several real hitrobot-server processes joined by Zenoh (``--bus zenoh``) on loopback:
topics in every encoding, latched late joiners, services, actions, the robot on one server
driven from another, discovery, kill -9 and restart."""

from __future__ import annotations

import asyncio
import math
import socket
import struct
import threading
import time

import orjson
import pytest
import roslibpy

from hitrobot_server.protocol import png
from tests.helpers import ServerProcess, Watcher, WsClient

ODOM = "/slamware_ros_sdk_server_node/odom"
SCAN = "/slamware_ros_sdk_server_node/scan"
MAP = "/slamware_ros_sdk_server_node/map"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def zenoh_server(*, listen: int | None = None, connect: int | None = None,
                 robot: str = "none", extra: tuple[str, ...] = ()) -> ServerProcess:
    args = ["--bus", "zenoh", "--log-level", "warning", *extra]
    if listen is not None:
        args += ["--zenoh-listen", f"tcp/127.0.0.1:{listen}"]
    if connect is not None:
        args += ["--zenoh-connect", f"tcp/127.0.0.1:{connect}"]
    return ServerProcess(*args, robot=robot)


async def until(probe, timeout: float, what: str):
    """Repeat a round trip (``probe`` awaits a reply) until it returns something truthy."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = await probe()
        if value:
            return value
        await asyncio.sleep(0.05)
    raise AssertionError(f"timed out after {timeout}s waiting for {what}")


async def rosapi(client: WsClient, name: str, **args) -> dict:
    reply = await client.call(f"/rosapi/{name}", args)
    assert reply["result"], reply
    return reply["values"]


async def until_listed(client: WsClient, listing: str, name: str, timeout: float) -> None:
    """Wait until rosapi's ``topics``/``services``/``action_servers`` on ``client``'s server
    lists ``name``."""

    async def listed() -> bool:
        return name in (await rosapi(client, listing))[listing]

    await until(listed, timeout, f"{name} in {listing}")


async def sees_subscriber(client: WsClient, topic: str, count: int = 1) -> bool:
    return len((await rosapi(client, "subscribers", topic=topic))["subscribers"]) >= count


@pytest.fixture(scope="module")
def pair():
    """Server A listens, server B connects; no robot."""
    port = free_port()
    a = zenoh_server(listen=port)
    a.zenoh_port = port
    b = zenoh_server(connect=port)
    yield a, b
    b.stop()
    a.stop()


@pytest.fixture
async def clients(pair):
    a, b = pair
    opened: list[WsClient] = []

    async def open_on(server: ServerProcess) -> WsClient:
        c = await WsClient.open(server.port)
        opened.append(c)
        return c

    yield open_on
    for c in opened:
        await c.close()


async def test_b_subscribers_get_what_a_publishes_in_every_encoding(pair, clients):
    a, b = pair
    pub = await clients(a)
    await pub.send({"op": "advertise", "topic": "/zt/chatter", "type": "std_msgs/String"})
    subs = {}
    for compression in ("none", "png", "cbor", "cbor-raw"):
        c = subs[compression] = await clients(b)
        await c.send({"op": "subscribe", "topic": "/zt/chatter", "type": "std_msgs/String",
                      "compression": compression})
    throttled = await clients(b)
    await throttled.send({"op": "subscribe", "topic": "/zt/chatter", "throttle_rate": 600_000})

    received: list[dict] = []
    got = threading.Event()
    ros = roslibpy.Ros(host="127.0.0.1", port=b.port)
    ros.run(timeout=10)
    try:
        listener = roslibpy.Topic(ros, "/zt/chatter", "std_msgs/String")

        def on_message(m: dict) -> None:
            received.append(m)
            if len(received) >= 3:
                got.set()

        listener.subscribe(on_message)
        await until(lambda: sees_subscriber(pub, "/zt/chatter", 6), 15, "B's subscribers on A")
        for i in range(3):
            await pub.send({"op": "publish", "topic": "/zt/chatter", "msg": {"data": f"hi {i}"}})

        plain = [await subs["none"].expect(op="publish", topic="/zt/chatter") for _ in range(3)]
        assert [m["msg"]["data"] for m in plain] == ["hi 0", "hi 1", "hi 2"]
        op = await subs["png"].expect(op="png")
        assert orjson.loads(png.decode(op["data"]))["msg"] == {"data": "hi 0"}
        binary = await subs["cbor"].expect(op="publish")
        assert binary["_binary"] and binary["msg"] == {"data": "hi 0"}
        raw = (await subs["cbor-raw"].expect(op="publish"))["msg"]["bytes"]
        assert raw == struct.pack("<I", 4) + b"hi 0"  # ROS 1 wire bytes of std_msgs/String
        assert (await throttled.expect(op="publish"))["msg"] == {"data": "hi 0"}
        assert await asyncio.to_thread(got.wait, 10), received
        assert [m["data"] for m in received] == ["hi 0", "hi 1", "hi 2"]
        await throttled.expect_none(op="publish")  # the throttle holds the other two back
        listener.unsubscribe()
    finally:
        ros.close()


async def test_latched_topic_reaches_a_late_joiner_on_another_server(pair, clients):
    a, b = pair
    pub = await clients(a)
    await pub.send({"op": "advertise", "topic": "/zt/latched", "type": "std_msgs/String",
                    "latch": True})
    await pub.send({"op": "publish", "topic": "/zt/latched", "msg": {"data": "the map"}})
    probe = await clients(b)

    await until_listed(probe, "topics", "/zt/latched", 10)
    late = await clients(b)
    await late.send({"op": "subscribe", "topic": "/zt/latched"})  # no type: B asks A's token
    msg = await late.expect(op="publish", topic="/zt/latched", timeout=10)
    assert msg["msg"] == {"data": "the map"}
    second = await clients(b)  # a later one on B gets it from B's own latch
    await second.send({"op": "subscribe", "topic": "/zt/latched"})
    assert (await second.expect(op="publish", topic="/zt/latched"))["msg"]["data"] == "the map"


async def test_both_servers_publishing_one_topic_do_not_echo(pair, clients):
    a, b = pair
    on_a, on_b = await clients(a), await clients(b)
    for c in (on_a, on_b):
        await c.send({"op": "advertise", "topic": "/zt/both", "type": "std_msgs/String"})
        await c.send({"op": "subscribe", "topic": "/zt/both", "type": "std_msgs/String"})
    await until(lambda: sees_subscriber(on_a, "/zt/both", 2), 10, "B's subscriber on A")
    await until(lambda: sees_subscriber(on_b, "/zt/both", 2), 10, "A's subscriber on B")
    await on_a.send({"op": "publish", "topic": "/zt/both", "msg": {"data": "from a"}})
    await on_b.send({"op": "publish", "topic": "/zt/both", "msg": {"data": "from b"}})
    for c in (on_a, on_b):
        got = [(await c.expect(op="publish", topic="/zt/both"))["msg"]["data"] for _ in range(2)]
        assert sorted(got) == ["from a", "from b"]
    for c in (on_a, on_b):
        await c.expect_none(op="publish", topic="/zt/both", timeout=0.5)


async def test_service_on_a_called_from_b(pair, clients):
    a, b = pair
    provider, caller = await clients(a), await clients(b)
    await provider.send({"op": "advertise_service", "service": "/zt/toggle",
                         "type": "std_srvs/SetBool"})

    await until_listed(caller, "services", "/zt/toggle", 10)
    assert (await rosapi(caller, "service_type", service="/zt/toggle"))["type"] == (
        "std_srvs/SetBool")
    await caller.send({"op": "call_service", "id": "c1", "service": "/zt/toggle",
                       "args": {"data": True}})
    req = await provider.expect(op="call_service", service="/zt/toggle")
    assert req["args"] == {"data": True}
    await provider.send({"op": "service_response", "service": "/zt/toggle", "id": req["id"],
                         "values": {"success": True, "message": "on"}, "result": True})
    reply = await caller.expect(op="service_response", id="c1")
    assert reply["result"] and reply["values"] == {"success": True, "message": "on"}

    await caller.send({"op": "call_service", "id": "c2", "service": "/zt/toggle",
                       "args": {"data": False}})
    req = await provider.expect(op="call_service", service="/zt/toggle")
    await provider.send({"op": "service_response", "service": "/zt/toggle", "id": req["id"],
                         "values": "the switch is stuck", "result": False})
    reply = await caller.expect(op="service_response", id="c2")
    assert not reply["result"] and "the switch is stuck" in reply["values"]

    await caller.send({"op": "call_service", "id": "c3", "service": "/zt/toggle",
                       "args": {"data": True}, "timeout": 0.5})
    await provider.expect(op="call_service", service="/zt/toggle")  # and never answers
    reply = await caller.expect(op="service_response", id="c3")
    assert not reply["result"] and "did not answer within 0.5 s" in reply["values"]

    reply = await caller.call("/zt/nobody_provides_this")
    assert not reply["result"] and "does not exist" in reply["values"]


async def test_a_withdrawn_service_leaves_the_other_servers_lists(pair, clients):
    a, b = pair
    provider, watcher = await clients(a), await clients(b)
    await provider.send({"op": "advertise_service", "service": "/zt/gone",
                         "type": "std_srvs/SetBool"})
    await until_listed(watcher, "services", "/zt/gone", 10)
    node = (await rosapi(watcher, "service_node", service="/zt/gone"))["node"]
    assert node in (await rosapi(watcher, "nodes"))["nodes"]
    await provider.close()  # the client goes, and its service with it

    async def gone() -> bool:
        services = (await rosapi(watcher, "services"))["services"]
        return "/zt/gone" not in services and node not in (await rosapi(watcher, "nodes"))["nodes"]

    await until(gone, 10, "the service and its node gone from B's lists")


async def test_client_action_on_a_with_goal_feedback_and_cancel_from_b(pair, clients):
    a, b = pair
    provider, caller = await clients(a), await clients(b)
    await provider.send({"op": "advertise_action", "action": "/zt/fib",
                         "type": "actionlib/action/TwoInts"})

    await until_listed(caller, "action_servers", "/zt/fib", 10)
    await caller.send({"op": "send_action_goal", "id": "g1", "action": "/zt/fib",
                       "action_type": "actionlib/TwoInts", "args": {"a": 2, "b": 3},
                       "feedback": True})
    goal = await provider.expect(op="send_action_goal", action="/zt/fib")
    assert goal["args"] == {"a": 2, "b": 3}
    await provider.send({"op": "action_result", "id": goal["id"], "action": "/zt/fib",
                         "values": {"sum": 5}, "status": 4, "result": True})
    res = await caller.expect(op="action_result", id="g1")
    assert res["status"] == 4 and res["result"] and res["values"] == {"sum": 5}

    await caller.send({"op": "send_action_goal", "id": "g2", "action": "/zt/fib",
                       "action_type": "actionlib/TwoInts", "args": {"a": 1, "b": 1}})
    goal = await provider.expect(op="send_action_goal", action="/zt/fib")
    await caller.send({"op": "cancel_action_goal", "id": "g2", "action": "/zt/fib"})
    cancel = await provider.expect(op="cancel_action_goal", id=goal["id"])
    assert cancel["action"] == "/zt/fib"
    await provider.send({"op": "action_result", "id": goal["id"], "action": "/zt/fib",
                         "values": "cancelled on request", "status": 5, "result": False})
    res = await caller.expect(op="action_result", id="g2")
    assert res["status"] == 5 and not res["result"] and res["values"] == "cancelled on request"


@pytest.fixture(scope="module")
def robot_pair():
    """The simulated robot on A only; B runs the bridge alone."""
    port = free_port()
    a = zenoh_server(listen=port, robot="sim", extra=("--sim-speed", "4"))
    b = zenoh_server(connect=port)
    yield a, b
    b.stop()
    a.stop()


async def test_robot_on_a_is_seen_and_driven_from_b(robot_pair):
    a, b = robot_pair
    w = await Watcher.open(b.port)
    try:
        for topic in (ODOM, SCAN, MAP, "/tf"):
            await w.subscribe(topic)
        await w.until(lambda: w.latest(ODOM) and w.latest(SCAN) and w.latest("/tf"), 20,
                      "odom, scan and tf on B")
        await w.until(lambda: w.latest(MAP), 20, "the latched map on B")
        grid = w.latest(MAP)
        assert grid["info"]["width"] > 0 and len(grid["data"]) == (
            grid["info"]["width"] * grid["info"]["height"])
        assert len(w.latest(SCAN)["ranges"]) == 360
        start = w.latest(ODOM)["pose"]["pose"]["position"]

        await w.subscribe("/move_base/result", "move_base_msgs/MoveBaseActionResult")
        await w.publish("/move_base/goal", {
            "goal_id": {"id": "from-b"},
            "goal": {"target_pose": {"header": {"frame_id": "map"}, "pose": {
                "position": {"x": start["x"] + 1.0, "y": start["y"], "z": 0.0},
                "orientation": {"w": 1.0}}}},
        }, "move_base_msgs/MoveBaseActionGoal")
        await w.until(lambda: w.latest("/move_base/result"), 60, "move_base's result on B")
        result = w.latest("/move_base/result")
        assert result["status"]["goal_id"]["id"] == "from-b"
        assert result["status"]["status"] == 3, result  # SUCCEEDED
        here = w.latest(ODOM)["pose"]["pose"]["position"]
        assert math.dist((here["x"], here["y"]), (start["x"] + 1.0, start["y"])) < 0.5

        await w.subscribe("/ros_mode")
        await w.until(lambda: w.latest("/ros_mode"), 10, "A's latched mode on B")
        await w.publish("/cmd_string", {"data": "gmapping"}, "std_msgs/String")
        await w.until(lambda: w.latest("/ros_mode")["data"] == "gmapping", 15,
                      "the mode switched by a command sent on B")
        await w.publish("/cmd_string", {"data": "navigation"})
        await w.until(lambda: w.latest("/ros_mode")["data"] == "navigation", 15, "back")
    finally:
        await w.close()


async def test_nav2_action_on_a_with_feedback_and_cancel_from_b(robot_pair):
    a, b = robot_pair
    c = await WsClient.open(b.port)
    try:
        await until_listed(c, "action_servers", "/follow_path", 20)
        nodes = set((await rosapi(c, "nodes"))["nodes"])  # B runs none of these itself
        assert {"/nav2_actions", "/graph", "/locomotion", "/map_files", "/move_base",
                "/robot_pose_publisher"} <= nodes, nodes

        await c.send({"op": "send_action_goal", "id": "plan", "action": "/compute_path_to_pose",
                      "action_type": "nav2_msgs/action/ComputePathToPose",
                      "args": {"goal": {"header": {"frame_id": "map"}, "pose": {
                          "position": {"x": 20.0, "y": 8.2, "z": 0.0},
                          "orientation": {"w": 1.0}}}}})
        plan = await c.expect(op="action_result", id="plan", timeout=30)
        assert plan["status"] == 4 and len(plan["values"]["path"]["poses"]) > 10, plan
        await c.send({"op": "send_action_goal", "id": "far", "action": "/follow_path",
                      "action_type": "nav2_msgs/action/FollowPath",
                      "args": {"path": plan["values"]["path"]}, "feedback": True})
        fb = await c.expect(lambda m: m["values"]["speed"] > 0.05, op="action_feedback",
                            id="far", timeout=30)
        assert fb["values"]["distance_to_goal"] > 1.0
        await c.send({"op": "cancel_action_goal", "id": "far", "action": "/follow_path"})
        res = await c.expect(op="action_result", id="far", timeout=20)
        assert res["status"] == 5, res
    finally:
        await c.close()


async def test_three_servers_kill_and_restart():
    port = free_port()
    a = zenoh_server(listen=port)
    b = zenoh_server(connect=port)
    c = zenoh_server(connect=port)
    opened: list[WsClient] = []
    try:
        ca, cb, cc = [await WsClient.open(s.port) for s in (a, b, c)]
        opened += [ca, cb, cc]
        await ca.send({"op": "advertise", "topic": "/zt/from_a", "type": "std_msgs/String"})
        for client in (cb, cc):
            await client.send({"op": "subscribe", "topic": "/zt/from_a",
                               "type": "std_msgs/String"})
        await until(lambda: sees_subscriber(ca, "/zt/from_a", 2), 15, "B and C on A")
        await ca.send({"op": "publish", "topic": "/zt/from_a", "msg": {"data": "one"}})
        for client in (cb, cc):
            assert (await client.expect(op="publish"))["msg"] == {"data": "one"}

        # B and C both joined through A; they also reach each other
        await cc.send({"op": "advertise", "topic": "/zt/from_c", "type": "std_msgs/String"})
        await cb.send({"op": "subscribe", "topic": "/zt/from_c", "type": "std_msgs/String"})
        await until(lambda: sees_subscriber(cc, "/zt/from_c", 1), 15, "B's subscriber on C")
        await cc.send({"op": "publish", "topic": "/zt/from_c", "msg": {"data": "c to b"}})
        assert (await cb.expect(op="publish", topic="/zt/from_c"))["msg"] == {"data": "c to b"}

        async def nodes_of(client: WsClient) -> list[str]:
            return (await rosapi(client, "nodes"))["nodes"]

        async def topics_of(client: WsClient) -> list[str]:
            return (await rosapi(client, "topics"))["topics"]

        a_node = next(n for n in (await rosapi(ca, "publishers", topic="/zt/from_a"))[
            "publishers"])
        assert a_node in await nodes_of(cc)  # C lists A's client node

        # a goal and a call in flight to A when it dies
        await ca.send({"op": "advertise_action", "action": "/zt/slow",
                       "type": "actionlib/action/TwoInts"})
        await ca.send({"op": "advertise_service", "service": "/zt/slow_srv",
                       "type": "std_srvs/SetBool"})

        async def provided() -> bool:
            return ("/zt/slow" in (await rosapi(cb, "action_servers"))["action_servers"]
                    and "/zt/slow_srv" in (await rosapi(cb, "services"))["services"])

        await until(provided, 10, "A's action and service on B")
        await cb.send({"op": "send_action_goal", "id": "doomed", "action": "/zt/slow",
                       "action_type": "actionlib/TwoInts", "args": {"a": 1, "b": 2}})
        await cb.send({"op": "call_service", "id": "doomed_call", "service": "/zt/slow_srv",
                       "args": {"data": True}})
        arrived: set[str] = set()
        while len(arrived) < 2:  # both reached A's provider (in either order)
            m = await ca.expect(lambda m: m.get("op") in ("send_action_goal", "call_service"))
            arrived.add(m["op"])

        a.proc.kill()  # kill -9: no goodbye, Zenoh notices the session is gone
        a.proc.wait(10)
        ended: dict[str, dict] = {}
        while len(ended) < 2:  # the goal and the call both fail, in either order
            m = await cb.expect(lambda m: m.get("id") in ("doomed", "doomed_call")
                                and m.get("op") != "status", timeout=20)
            ended[m["id"]] = m
        assert ended["doomed"]["status"] == 6 and not ended["doomed"]["result"]
        assert "gone" in ended["doomed"]["values"]
        assert not ended["doomed_call"]["result"] and "gone" in ended["doomed_call"]["values"]

        async def a_gone() -> bool:
            return a_node not in (await rosapi(cb, "publishers", topic="/zt/from_a"))[
                "publishers"] and a_node not in await nodes_of(cb)

        await until(a_gone, 20, "A's publisher to leave B's rosapi")
        await until(lambda: _missing(nodes_of(cc), a_node), 20, "A's node to leave C's rosapi")

        a = zenoh_server(listen=port)
        ca = await WsClient.open(a.port)
        opened.append(ca)
        await ca.send({"op": "advertise", "topic": "/zt/from_a", "type": "std_msgs/String"})
        await until(lambda: sees_subscriber(ca, "/zt/from_a", 2), 20, "B and C on the new A")
        await ca.send({"op": "publish", "topic": "/zt/from_a", "msg": {"data": "two"}})
        for client in (cb, cc):
            assert (await client.expect(op="publish"))["msg"] == {"data": "two"}
        assert "/zt/from_a" in await topics_of(cb)
    finally:
        for client in opened:
            await client.close()
        for s in (a, b, c):
            s.stop()


async def _missing(names, name: str) -> bool:
    return name not in await names


CHATTER_KEY = ("0/zt/ros2_chatter/std_msgs::msg::dds_::String_/"
               "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18")
TALKER_KEY = CHATTER_KEY.replace("ros2_chatter", "ros2_talker")


def ros2_cdr_string(text: str) -> bytes:
    raw = text.encode() + b"\0"
    return b"\x00\x01\x00\x00" + struct.pack("<I", len(raw)) + raw


async def test_a_plain_zenoh_peer_in_rmw_zenoh_format_talks_with_a_server(pair, clients):
    """A stand-in for a ROS 2 node on rmw_zenoh: a bare Zenoh session whose keys, tokens and
    payloads are written out by hand here (not made with the server's own functions)."""
    import zenoh

    a, _b = pair
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    conf.insert_json5("connect/endpoints", f'["tcp/127.0.0.1:{a.zenoh_port}"]')
    session = await asyncio.to_thread(zenoh.open, conf)
    samples: asyncio.Queue = asyncio.Queue()
    loop = asyncio.get_running_loop()
    try:
        zid = str(session.zid())
        qos = "::,10:,:,:,,"
        hash_ = CHATTER_KEY.rsplit("/", 1)[1]
        tokens = [
            session.liveliness().declare_token(f"@ros2_lv/0/{zid}/0/0/NN/%/%/ros2_listener"),
            session.liveliness().declare_token(
                f"@ros2_lv/0/{zid}/0/11/MS/%/%/ros2_listener/%zt%ros2_chatter/"
                f"std_msgs::msg::dds_::String_/{hash_}/{qos}"),
            session.liveliness().declare_token(
                f"@ros2_lv/0/{zid}/0/12/MP/%/%/ros2_listener/%zt%ros2_talker/"
                f"std_msgs::msg::dds_::String_/{hash_}/{qos}"),
        ]
        sub = session.declare_subscriber(CHATTER_KEY, lambda s: loop.call_soon_threadsafe(
            samples.put_nowait, (s.payload.to_bytes(), s.attachment.to_bytes())))

        c = await clients(a)
        await c.send({"op": "advertise", "topic": "/zt/ros2_chatter", "type": "std_msgs/String"})
        await until(lambda: _has(rosapi(c, "subscribers", topic="/zt/ros2_chatter"),
                                 "subscribers", "/ros2_listener"), 10, "the ROS 2 listener")
        assert "/ros2_listener" in (await rosapi(c, "nodes"))["nodes"]
        await c.send({"op": "publish", "topic": "/zt/ros2_chatter", "msg": {"data": "hello"}})
        payload, attachment = await asyncio.wait_for(samples.get(), 10)
        assert payload == ros2_cdr_string("hello")
        seq, stamp, gid_len = struct.unpack_from("<qqB", attachment)
        assert gid_len == 16 and len(attachment) == 33 and seq > 0 and stamp > 1.6e18

        # and the other way: the "ROS 2 node" publishes, a client on A subscribes by name only
        await c.send({"op": "subscribe", "topic": "/zt/ros2_talker"})

        async def server_subscribed() -> bool:  # A's MS token, seen from the bare session
            replies = await asyncio.to_thread(
                lambda: list(session.liveliness().get("@ros2_lv/0/**", timeout=5)))
            keys = [str(r.ok.key_expr) for r in replies if r.ok is not None]
            return any("/MS/" in k and "/%zt%ros2_talker/" in k for k in keys)

        await until(server_subscribed, 10, "the server's subscription token")
        session.put(TALKER_KEY, ros2_cdr_string("from ros 2"),
                    attachment=struct.pack("<qqB", 1, time.time_ns(), 16) + bytes(16))
        msg = await c.expect(op="publish", topic="/zt/ros2_talker", timeout=10)
        assert msg["msg"] == {"data": "from ros 2"}
        sub.undeclare()
        for t in tokens:
            t.undeclare()
    finally:
        await asyncio.to_thread(session.close)


async def _has(reply, field: str, name: str) -> bool:
    return name in (await reply)[field]

"""The real roslibpy client (Twisted transport) against a real hitrobot-server process."""

from __future__ import annotations

import math
import threading
import time

import pytest
import roslibpy
import roslibpy.tf

from tests.helpers import ServerProcess, connect_roslibpy


@pytest.fixture
def ros(server_process):
    clients = []

    def connect() -> roslibpy.Ros:
        clients.append(connect_roslibpy(server_process.port))
        return clients[-1]

    yield connect
    for r in clients:
        r.close()


@pytest.fixture(scope="module")
def sim_process():
    proc = ServerProcess(robot="sim")
    yield proc
    proc.stop()


@pytest.fixture
def sim_ros(sim_process):
    r = connect_roslibpy(sim_process.port)
    yield r
    r.close()


def wait_for(predicate, timeout: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.02)
    return predicate()


def test_pub_sub_between_two_clients(ros):
    a, b = ros(), ros()
    received: list[dict] = []
    listener = roslibpy.Topic(b, "/rlp/chatter", "std_msgs/String")
    listener.subscribe(received.append)
    talker = roslibpy.Topic(a, "/rlp/chatter", "std_msgs/String")
    talker.advertise()
    assert wait_for(lambda: talker.is_advertised)
    b.get_time()  # round trip: b's subscribe (sent before it) has been handled
    for i in range(5):
        talker.publish(roslibpy.Message({"data": f"hello {i}"}))
    assert wait_for(lambda: len(received) >= 5)
    assert [m["data"] for m in received[:5]] == [f"hello {i}" for i in range(5)]
    listener.unsubscribe()
    talker.unadvertise()


def test_client_advertised_service_called_by_other_client(ros):
    provider, caller = ros(), ros()

    def handler(request, response):
        response["success"] = bool(request["data"])
        response["message"] = "flipped" if request["data"] else "kept"
        return True

    service = roslibpy.Service(provider, "/rlp/toggle", "std_srvs/SetBool")
    service.advertise(handler)
    provider.get_time()  # round trip: the advertise (sent before it) has been handled
    client = roslibpy.Service(caller, "/rlp/toggle", "std_srvs/SetBool")
    result = client.call(roslibpy.ServiceRequest({"data": True}), timeout=5)
    assert result["success"] is True and result["message"] == "flipped"
    service.unadvertise()


def test_params_and_get_time_and_rosapi(ros):
    r = ros()
    param = roslibpy.Param(r, "/rlp/max_speed")
    param.set(0.7)  # a blocking service call: set once it returns
    assert param.get(timeout=5) == 0.7
    assert "/rlp/max_speed" in r.get_params()
    param.delete()
    t = r.get_time()
    assert abs(t["secs"] - time.time()) < 5
    roslibpy.Topic(r, "/rlp/listed", "geometry_msgs/Twist").advertise()  # before the call below
    assert "/rlp/listed" in r.get_topics()
    assert r.get_topic_type("/rlp/listed") == "geometry_msgs/Twist"
    assert "/rosapi/get_time" in r.get_services()
    details = r.get_message_details("geometry_msgs/Twist")
    assert details["typedefs"][0]["fieldnames"] == ["linear", "angular"]


def test_failed_call_reaches_errback(ros):
    r = ros()
    done = threading.Event()
    errors: list = []
    svc = roslibpy.Service(r, "/rlp/missing", "std_srvs/Empty")
    svc.call(roslibpy.ServiceRequest(), callback=lambda _r: done.set(),
             errback=lambda e: (errors.append(e), done.set()))
    assert done.wait(5)
    assert errors and "does not exist" in str(errors[0])


def failed_call(caller: roslibpy.Ros, name: str, type_name: str, a: int, b: int) -> list:
    """Call an AddTwoInts service expecting failure; what reached the errback."""
    done = threading.Event()
    errors: list = []
    client = roslibpy.Service(caller, name, type_name)
    client.call(roslibpy.ServiceRequest({"a": a, "b": b}), callback=lambda _r: done.set(),
                errback=lambda e: (errors.append(e), done.set()))
    assert done.wait(5)
    return errors


def test_provider_result_false_values_reach_the_caller(ros):
    """roslibpy's own AddTwoInts test: a handler returning False still hands over its values,
    and, as rosbridge ignores a provider's ``result``, the caller's call succeeds (issue 49:
    ``client.call`` returns ``{"sum": 42}``)."""
    provider, caller = ros(), ros()

    def add(request, response):
        response["sum"] = request["a"] + request["b"]
        return False

    service = roslibpy.Service(provider, "/rlp/add_two_ints", "rospy_tutorials/AddTwoInts")
    service.advertise(add)
    assert wait_for(lambda: "/rlp/add_two_ints" in caller.get_services())
    client = roslibpy.Service(caller, "/rlp/add_two_ints", "rospy_tutorials/AddTwoInts")
    assert client.call(roslibpy.ServiceRequest({"a": 2, "b": 40}), timeout=5) == {"sum": 42}
    service.unadvertise()


def test_provider_returning_none_still_answers_the_caller(ros):
    """A roslibpy handler returning None sends result:null; the caller must not hang."""
    provider, caller = ros(), ros()
    service = roslibpy.Service(provider, "/rlp/add_none", "example_interfaces/AddTwoInts")
    service.advertise(lambda request, response: None)
    assert wait_for(lambda: "/rlp/add_none" in caller.get_services())
    errors = failed_call(caller, "/rlp/add_none", "example_interfaces/AddTwoInts", 1, 1)
    assert errors and "invalid response" in str(errors[0])
    service.unadvertise()


def test_rosout_is_found_like_foxglove_finds_it(sim_ros, sim_process):
    """Foxglove and Lichtblick read the ROS version from /rosout's type in rosapi's topic list,
    and show the records: the bridge's own "client connected" is one."""
    topics = roslibpy.Service(sim_ros, "/rosapi/topics", "rosapi/Topics").call(
        roslibpy.ServiceRequest(), timeout=5)
    assert dict(zip(topics["topics"], topics["types"], strict=True))["/rosout"] == (
        "rosgraph_msgs/Log")
    assert sim_ros.get_topic_type("/rosout") == "rosgraph_msgs/Log"
    records: list[dict] = []
    listener = roslibpy.Topic(sim_ros, "/rosout", "rosgraph_msgs/Log")
    listener.subscribe(records.append)
    deadline = time.monotonic() + 10
    other = None
    while time.monotonic() < deadline and not any("connected" in r["msg"] for r in records):
        if other is None and wait_for(lambda: listener.is_subscribed, 1):
            other = connect_roslibpy(sim_process.port)  # the server logs this connection
        time.sleep(0.05)
    connected = [r for r in records if "connected" in r["msg"]]
    assert connected and connected[0]["name"] == "/hitrobot_server"
    assert connected[0]["level"] == 2 and connected[0]["header"]["stamp"]["secs"] > 1.6e9
    listener.unsubscribe()
    if other is not None:
        other.close()


def test_tf_client_follows_the_robot_as_it_drives(sim_ros):
    """roslibpy's TFClient (the /republish_tfs form) sees base_link move in map."""
    tf = roslibpy.tf.TFClient(sim_ros, fixed_frame="map", angular_threshold=0.01,
                              translation_threshold=0.01, rate=10.0)
    seen: list[dict] = []
    tf.subscribe("base_link", seen.append)
    assert wait_for(lambda: seen, 10)
    start = seen[-1]["translation"]
    odom: list[dict] = []
    roslibpy.Topic(sim_ros, "/odom", "nav_msgs/Odometry").subscribe(odom.append)
    cmd = roslibpy.Topic(sim_ros, "/cmd_vel", "geometry_msgs/Twist")
    cmd.advertise()
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline and math.dist(
            (seen[-1]["translation"]["x"], seen[-1]["translation"]["y"]),
            (start["x"], start["y"])) < 0.3:
        cmd.publish(roslibpy.Message({"linear": {"x": 0.3, "y": 0.0, "z": 0.0},
                                      "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}))
        time.sleep(0.1)  # the drive command's own rate, not a synchronisation
    cmd.publish(roslibpy.Message({}))
    moved = seen[-1]["translation"]
    assert math.dist((moved["x"], moved["y"]), (start["x"], start["y"])) >= 0.3

    def agrees() -> bool:  # once stopped, TF and odometry name the same place
        if not odom:
            return False
        p = odom[-1]["pose"]["pose"]["position"]
        t = seen[-1]["translation"]
        return abs(odom[-1]["twist"]["twist"]["linear"]["x"]) < 1e-3 and math.dist(
            (p["x"], p["y"]), (t["x"], t["y"])) < 0.02

    assert wait_for(agrees, 10)
    tf.dispose()


@pytest.fixture(scope="module")
def demo_process():
    proc = ServerProcess("--demo-services")
    yield proc
    proc.stop()


def test_demo_services_serve_the_tutorials_to_roslibpy(demo_process):
    """What roslibpy's release suite runs against the rosbridge test image."""
    ros = connect_roslibpy(demo_process.port)
    try:
        adder = roslibpy.Service(ros, "/add_two_ints", "example_interfaces/srv/AddTwoInts")
        assert adder.call(roslibpy.ServiceRequest({"a": 2, "b": 40}), timeout=10)["sum"] == 42
        client = roslibpy.ActionClient(ros, "/fibonacci", "example_interfaces/action/Fibonacci")
        feedback: list[list[int]] = []
        results: list[dict] = []
        goal_id = client.send_goal(roslibpy.Goal({"order": 8}), results.append,
                                   lambda f: feedback.append(f["sequence"]), results.append)
        client.wait_goal(goal_id, 20)
        assert results[0]["values"]["sequence"] == [0, 1, 1, 2, 3, 5, 8, 13, 21]
        assert results[0]["status"] == roslibpy.GoalStatus.SUCCEEDED
        assert feedback[0] == [0, 1, 1] and feedback[-1] == [0, 1, 1, 2, 3, 5, 8, 13, 21]

        cancelled: list[dict] = []
        first: list[list[int]] = []
        goal_id = client.send_goal(roslibpy.Goal({"order": 40}), cancelled.append,
                                   first.append, cancelled.append)
        assert wait_for(lambda: first)  # running: feedback came
        client.cancel_goal(goal_id)
        client.wait_goal(goal_id, 20)
        assert cancelled[0]["status"] == roslibpy.GoalStatus.CANCELED
        assert len(cancelled[0]["values"]["sequence"]) < 41
    finally:
        ros.close()


def test_demo_services_are_off_by_default(sim_ros):
    assert "/add_two_ints" not in sim_ros.get_services()
    assert not [t for t in sim_ros.get_topics() if t.startswith("/fibonacci/")]

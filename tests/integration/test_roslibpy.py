"""The real roslibpy client (Twisted transport) against a real hitrobot-server process."""

from __future__ import annotations

import threading
import time

import pytest
import roslibpy


@pytest.fixture
def ros(server_process):
    clients = []

    def connect() -> roslibpy.Ros:
        r = roslibpy.Ros(host="127.0.0.1", port=server_process.port)
        r.run(timeout=10)
        assert r.is_connected
        clients.append(r)
        return r

    yield connect
    for r in clients:
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
    time.sleep(0.2)
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
    time.sleep(0.3)
    client = roslibpy.Service(caller, "/rlp/toggle", "std_srvs/SetBool")
    result = client.call(roslibpy.ServiceRequest({"data": True}), timeout=5)
    assert result["success"] is True and result["message"] == "flipped"
    service.unadvertise()


def test_params_and_get_time_and_rosapi(ros):
    r = ros()
    param = roslibpy.Param(r, "/rlp/max_speed")
    param.set(0.7)
    time.sleep(0.2)
    assert param.get(timeout=5) == 0.7
    assert "/rlp/max_speed" in r.get_params()
    param.delete()
    t = r.get_time()
    assert abs(t["secs"] - time.time()) < 5
    roslibpy.Topic(r, "/rlp/listed", "geometry_msgs/Twist").advertise()
    time.sleep(0.3)
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

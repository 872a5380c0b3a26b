"""The rosbridge ops the server sends, built by the protocol floor (protocol/ops.py), called
directly."""

from __future__ import annotations

from hitrobot_server.protocol import ops


def test_answers_carry_the_request_id_only_when_it_had_one():
    assert ops.service_response("/add", "c1", {"sum": 3}, True) == {
        "op": "service_response", "service": "/add", "id": "c1", "values": {"sum": 3},
        "result": True}
    assert ops.service_response("/add", None, "refused", False) == {
        "op": "service_response", "service": "/add", "values": "refused", "result": False}
    assert ops.action_result("/fib", 7, {"sequence": [0, 1]}, 4, True) == {
        "op": "action_result", "action": "/fib", "id": 7, "values": {"sequence": [0, 1]},
        "status": 4, "result": True}
    assert "id" not in ops.action_result("/fib", None, "no", 0, False)
    assert ops.action_feedback("/fib", "g", {"partial": [0]}) == {
        "op": "action_feedback", "action": "/fib", "id": "g", "values": {"partial": [0]}}
    assert "id" not in ops.action_feedback("/fib", None, {})


def test_requests_handed_to_a_providing_client():
    assert ops.call_service("service_request:/add:1", "/add", {"a": 1, "b": 2}) == {
        "op": "call_service", "id": "service_request:/add:1", "service": "/add",
        "args": {"a": 1, "b": 2}}
    assert ops.send_action_goal("action_goal:/fib:1", "/fib",
                                     "example_interfaces/action/Fibonacci", {"order": 3}) == {
        "op": "send_action_goal", "id": "action_goal:/fib:1", "action": "/fib",
        "action_type": "example_interfaces/action/Fibonacci", "args": {"order": 3},
        "feedback": True}
    assert ops.cancel_action_goal("action_goal:/fib:1", "/fib") == {
        "op": "cancel_action_goal", "id": "action_goal:/fib:1", "action": "/fib"}

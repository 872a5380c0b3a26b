"""Parsing and validation of client→server ops against their declarative specs."""

import dataclasses

import pytest

from hitrobot_server.protocol.errors import ProtocolError
from hitrobot_server.protocol.ops import (
    ABSENT,
    OPS,
    Publish,
    Subscribe,
    _check_field,
    json_type,
    parse_message,
    validate_op,
)

# Realistic messages, as roslibjs / roslibpy / rosbridge clients send them.
VALID = [
    {"op": "fragment", "id": "m1", "data": "{}", "num": 0, "total": 1},
    {"op": "fragment", "id": 0, "data": "", "num": 3, "total": 4},
    {"op": "png", "data": "iVBORw0KGgo="},
    {"op": "set_level", "level": "info", "id": "lvl"},
    {"op": "set_level", "level": "none", "id": None},
    {
        "op": "auth",
        "mac": "ab" * 64,
        "client": "192.168.1.101",
        "dest": "192.168.1.111",
        "rand": "r",
        "t": 1700000000.25,
        "level": "admin",
        "end": 1700003600,
    },
    {
        "op": "advertise",
        "id": "advertise:/cmd_vel:1",
        "topic": "/cmd_vel",
        "type": "geometry_msgs/Twist",
        "latch": False,
        "queue_size": 100,
    },
    {"op": "unadvertise", "id": "advertise:/cmd_vel:1", "topic": "/cmd_vel"},
    {"op": "publish", "topic": "/cmd_vel", "msg": {"linear": {"x": 1}}, "latch": False},
    {"op": "publish", "topic": "/chatter", "msg": "bare value"},
    {"op": "publish", "topic": "/empty"},
    {
        "op": "subscribe",
        "id": "subscribe:/map:1",
        "type": "nav_msgs/OccupancyGrid",
        "topic": "/map",
        "compression": "png",
        "throttle_rate": 0,
        "queue_length": 0,
    },
    {"op": "subscribe", "topic": "/scan", "fragment_size": 1, "compression": "cbor-raw"},
    {"op": "unsubscribe", "id": "subscribe:/map:1", "topic": "/map"},
    {"op": "call_service", "id": 5, "service": "/rosapi/topics", "args": {}, "type": "x/Y"},
    {"op": "call_service", "service": "/add", "args": [1, 2], "timeout": 5},
    {"op": "call_service", "service": "/s", "args": None, "fragment_size": None, "timeout": None},
    {"op": "call_service", "service": "/s", "fragment_size": 10, "compression": "png"},
    {"op": "advertise_service", "service": "/trigger", "type": "std_srvs/Trigger"},
    {"op": "unadvertise_service", "service": "/trigger"},
    {"op": "service_response", "service": "/t", "id": "service_request:/t:1", "result": False},
    {"op": "service_response", "service": "/t", "id": 3, "values": {"a": 1}, "result": True},
    {"op": "advertise_action", "action": "/fib", "type": "example_interfaces/Fibonacci"},
    {"op": "unadvertise_action", "action": "/fib"},
    {
        "op": "send_action_goal",
        "id": "g1",
        "action": "/fib",
        "action_type": "example_interfaces/Fibonacci",
        "args": {"order": 3},
        "feedback": True,
    },
    {"op": "cancel_action_goal", "action": "/fib", "id": "g1"},
    {"op": "action_feedback", "action": "/fib", "id": "g1", "values": {"sequence": [0, 1]}},
    {"op": "action_result", "action": "/fib", "id": "g1", "status": 4, "result": True},
]


def error_of(msg) -> ProtocolError:
    with pytest.raises(ProtocolError) as info:
        validate_op(parse_message(msg))
    return info.value


def carries(value, msg: dict) -> bool:
    """Whether a validated op value is of the op's class and holds every field the message
    gave, as given (the same objects, not copies)."""
    spec = OPS[msg["op"]]
    return type(value) is spec.cls and all(
        getattr(value, name) is msg[name] for name in spec.names if name in msg
    )


def test_every_op_has_a_valid_example():
    assert {m["op"] for m in VALID} == set(OPS)


@pytest.mark.parametrize("msg", VALID, ids=lambda m: m["op"])
def test_valid_messages_pass_unchanged(msg):
    before = dict(msg)
    assert carries(validate_op(parse_message(msg)), msg)
    assert msg == before


def test_unknown_fields_are_ignored():
    msg = {"op": "subscribe", "topic": "/a", "extra": [1], "fragment_size": 5, "png": "x"}
    assert validate_op(msg) == Subscribe(topic="/a", fragment_size=5)
    assert not hasattr(validate_op(msg), "extra")


def test_op_values_are_frozen():
    op = validate_op({"op": "subscribe", "topic": "/a"})
    with pytest.raises(dataclasses.FrozenInstanceError):
        op.topic = "/b"


def test_left_out_fields_get_their_defaults():
    op = validate_op({"op": "subscribe", "topic": "/a"})
    assert (op.id, op.type, op.throttle_rate, op.queue_length) == (None, None, 0, 0)
    assert (op.fragment_size, op.compression) == (None, "none")


def test_publish_tells_a_left_out_msg_from_null_and_keeps_the_op():
    msg = {"op": "publish", "topic": "/a"}
    left_out = validate_op(msg)
    assert isinstance(left_out, Publish) and left_out.msg is ABSENT and left_out.raw is msg
    assert validate_op({"op": "publish", "topic": "/a", "msg": None}).msg is None


def test_spec_fields_are_the_value_fields_in_order():
    """The table is read from the classes: every field but ``raw`` is checked, in order."""
    for spec in OPS.values():
        names = tuple(f.name for f in dataclasses.fields(spec.cls) if f.name != "raw")
        assert names == spec.names
        assert spec.op == spec.cls.OP


SAMPLES = [None, True, False, 0, -1, 7, 1.5, float("nan"), "", "none", "png", {}, {"a": 1}, [],
           [1], b"x"]


def test_the_quick_type_check_never_passes_what_the_full_check_rejects():
    for spec in OPS.values():
        for field in spec.fields:
            for value in SAMPLES:
                quick = field.valid_types is None or type(value) in field.valid_types
                if quick:
                    assert _check_field(spec.op, field, value) is None, (spec.op, field, value)


@pytest.mark.parametrize(
    ("obj", "text"),
    [
        ([{"op": "publish"}], "must be a JSON object with a string field 'op', got array"),
        ("publish", "must be a JSON object with a string field 'op', got string"),
        (None, "got null"),
        ({"topic": "/a"}, "message has no field 'op'"),
        ({"op": 3}, "field 'op' must be a string, got integer"),
        ({"op": None}, "field 'op' must be a string, got null"),
    ],
)
def test_parse_message_names_op(obj, text):
    with pytest.raises(ProtocolError) as info:
        parse_message(obj)
    assert text in info.value.msg
    assert info.value.level == "error"


def test_parse_message_error_carries_valid_id_only():
    with pytest.raises(ProtocolError) as info:
        parse_message({"id": "x1", "topic": "/a"})
    assert info.value.id == "x1"
    with pytest.raises(ProtocolError) as info:
        parse_message({"id": ["x1"], "op": 1})
    assert info.value.id is None


def test_unknown_op():
    err = error_of({"op": "service_request", "id": 9})
    assert err.msg == "unknown op 'service_request'"
    assert err.id == 9


@pytest.mark.parametrize(
    ("op", "field"), [(op, name) for op, spec in OPS.items() for name in spec.required]
)
def test_missing_required_field(op, field):
    msg = dict(next(m for m in VALID if m["op"] == op and field in m))
    del msg[field]
    assert error_of(msg).msg == f"{op}: missing required field '{field}'"


@pytest.mark.parametrize(
    ("msg", "text"),
    [
        (
            {"op": "subscribe", "topic": "/a", "throttle_rate": "100"},
            "subscribe: field 'throttle_rate' must be an integer, got string",
        ),
        (
            {"op": "subscribe", "topic": "/a", "throttle_rate": 100.0},
            "subscribe: field 'throttle_rate' must be an integer, got number 100.0",
        ),
        (
            {"op": "subscribe", "topic": "/a", "queue_length": True},
            "subscribe: field 'queue_length' must be an integer, got boolean",
        ),
        (
            {"op": "subscribe", "topic": "/a", "throttle_rate": -1},
            "subscribe: field 'throttle_rate' must be 0 or greater, got -1",
        ),
        (
            {"op": "subscribe", "topic": "/a", "fragment_size": 0},
            "subscribe: field 'fragment_size' must be 1 or greater, got 0",
        ),
        (
            {"op": "subscribe", "topic": "/a", "compression": "zip"},
            "subscribe: field 'compression' must be one of 'none', 'png', 'cbor', 'cbor-raw', "
            "got 'zip'",
        ),
        (
            {"op": "subscribe", "topic": "/a", "fragment_size": None},
            "subscribe: field 'fragment_size' must be an integer, got null",
        ),
        ({"op": "subscribe", "topic": 5}, "subscribe: field 'topic' must be a string, got integer"),
        (
            {"op": "advertise", "topic": "/a", "type": "t", "latch": 1},
            "advertise: field 'latch' must be a boolean, got integer",
        ),
        (
            {"op": "call_service", "service": "/s", "args": "1 2"},
            "call_service: field 'args' must be an object, an array or null, got string",
        ),
        (
            {"op": "call_service", "service": "/s", "fragment_size": 0},
            "call_service: field 'fragment_size' must be 1 or greater, got 0",
        ),
        (
            {"op": "call_service", "service": "/s", "timeout": "5"},
            "call_service: field 'timeout' must be a number or null, got string",
        ),
        (
            {"op": "set_level", "level": "debug"},
            "set_level: field 'level' must be one of 'info', 'warning', 'error', 'none', "
            "got 'debug'",
        ),
        (
            {
                "op": "auth",
                "mac": "m",
                "client": "c",
                "dest": "d",
                "rand": "r",
                "t": "now",
                "level": "l",
                "end": 1,
            },
            "auth: field 't' must be a number, got string",
        ),
        (
            {"op": "action_feedback", "action": "/a", "id": "g", "values": [1]},
            "action_feedback: field 'values' must be an object, got array",
        ),
        (
            {"op": "action_result", "action": "/a", "id": "g", "status": 4.0, "result": True},
            "action_result: field 'status' must be an integer, got number 4.0",
        ),
        (
            {"op": "service_response", "service": "/s", "id": None, "result": True},
            "service_response: field 'id' must be a string or an integer, got null",
        ),
        (
            {"op": "fragment", "id": "f", "data": "x", "num": 0, "total": 0},
            "fragment: field 'total' must be 1 or greater, got 0",
        ),
    ],
)
def test_field_errors_name_op_and_field(msg, text):
    assert error_of(msg).msg == text


@pytest.mark.parametrize("bad_id", [True, 1.5, {"a": 1}, [1]])
def test_invalid_id_is_an_error_without_id(bad_id):
    err = error_of({"op": "unsubscribe", "topic": "/a", "id": bad_id})
    assert err.msg.startswith("unsubscribe: field 'id' must be a string, an integer or null")
    assert err.id is None


def test_error_carries_the_message_id():
    assert error_of({"op": "subscribe", "id": "sub-1", "topic": 1}).id == "sub-1"
    assert error_of({"op": "subscribe", "id": 0, "topic": 1}).id == 0


def test_id_null_means_no_id():
    assert validate_op({"op": "unsubscribe", "topic": "/a", "id": None})
    assert error_of({"op": "unsubscribe", "id": None}).id is None


@pytest.mark.parametrize(
    ("value", "name"),
    [
        (None, "null"),
        (True, "boolean"),
        (1, "integer"),
        (1.0, "number"),
        ("", "string"),
        ({}, "object"),
        ([], "array"),
        (b"\x00", "bytes"),
        (bytearray(b"\x00"), "bytes"),
    ],
)
def test_json_type(value, name):
    assert json_type(value) == name


def test_specs_are_consistent():
    for op, spec in OPS.items():
        assert spec.op == op
        assert len(set(spec.names)) == len(spec.names)
        assert "id" in spec.names
        for field in spec.fields:
            assert field.minimum is None or set(field.types) & {"integer", "number"}
            assert not field.enum or field.types == ("string",)

"""The Foxglove protocol core, called directly: parsing client frames, building server ones."""

from __future__ import annotations

import dataclasses
import json
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hitrobot_server.protocol import foxglove as fg


def test_subscribe_parses_ids_and_channels():
    op = fg.parse_text(json.dumps({"op": "subscribe",
                                   "subscriptions": [{"id": 3, "channelId": 7}, {"channelId": 8}]}))
    assert op == {"op": "subscribe", "subscriptions": [(3, 7), (None, 8)]}


@pytest.mark.parametrize(
    ("frame", "words"),
    [
        ("nope", "invalid JSON"),
        ("[1]", "JSON object"),
        ('{"op": 5}', "'op'"),
        ('{"op": "explode"}', "unknown op"),
        ('{"op": "subscribe"}', "'subscriptions' must be a list"),
        ('{"op": "subscribe", "subscriptions": [{"id": -1, "channelId": 1}]}',
         "subscriptions[].id"),
        ('{"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 4294967296}]}',
         "channelId"),
        ('{"op": "unsubscribe", "subscriptionIds": ["1"]}', "subscriptionIds"),
        ('{"op": "advertise", "channels": [{"id": 1, "topic": "", "encoding": "cdr",'
         ' "schemaName": "std_msgs/msg/String"}]}', "channels[].topic"),
        ('{"op": "getParameters", "parameterNames": [1]}', "parameterNames"),
        ('{"op": "getParameters", "parameterNames": [], "id": 5}', "'id'"),
        ('{"op": "setParameters", "parameters": [{"name": "/a", "value": "x",'
         ' "type": "float64"}]}', "float64"),
        ('{"op": "setParameters", "parameters": [{"name": "/a", "value": "!!",'
         ' "type": "byte_array"}]}', "base64"),
        ('{"op": "fetchAsset", "uri": "x"}', "requestId"),
    ],
)
def test_bad_text_frames_name_the_problem(frame, words):
    with pytest.raises(fg.FoxgloveError) as info:
        fg.parse_text(frame)
    assert words in str(info.value)


def test_each_op_parses_into_its_frozen_class():
    """``parse_op`` gives each JSON op its frozen value (checked fields, lists as tuples);
    the ops that may list thousands of entries name the field a session handles in steps."""
    sub = fg.parse_op(json.dumps({"op": "subscribe", "subscriptions": [
        {"id": 3, "channelId": 7}, {"channelId": 8}]}))
    assert sub == fg.Subscribe(((3, 7), (None, 8)))
    assert sub.LISTS == "subscriptions"
    with pytest.raises(dataclasses.FrozenInstanceError):
        sub.subscriptions = ()  # type: ignore[misc]
    assert fg.parse_op('{"op": "unsubscribe", "subscriptionIds": [1, 2]}') == \
        fg.Unsubscribe((1, 2))
    adv = fg.parse_op(json.dumps({"op": "advertise", "channels": [
        {"id": 1, "topic": "/t", "encoding": "cdr", "schemaName": "std_msgs/msg/String"}]}))
    assert adv == fg.Advertise((fg.ClientChannel(1, "/t", "cdr", "std_msgs/msg/String"),))
    assert fg.parse_op('{"op": "unadvertise", "channelIds": [4]}') == fg.Unadvertise((4,))
    assert fg.parse_op('{"op": "getParameters", "parameterNames": ["/a"], "id": "q"}') == \
        fg.GetParameters(("/a",), "q")
    assert fg.parse_op(json.dumps({"op": "setParameters", "parameters": [
        {"name": "/a", "value": 1.0, "type": "float64"}]})) == \
        fg.SetParameters((("/a", 1.0),), None)
    assert fg.parse_op('{"op": "subscribeParameterUpdates", "parameterNames": ["/a"]}') == \
        fg.SubscribeParameterUpdates(("/a",))
    assert fg.parse_op('{"op": "unsubscribeParameterUpdates", "parameterNames": []}') == \
        fg.UnsubscribeParameterUpdates(())
    assert fg.parse_op('{"op": "subscribeConnectionGraph"}') == fg.SubscribeConnectionGraph()
    assert fg.parse_op('{"op": "unsubscribeConnectionGraph"}') == \
        fg.UnsubscribeConnectionGraph()
    assert fg.parse_op('{"op": "fetchAsset", "requestId": 9, "uri": "package://x"}') == \
        fg.FetchAsset(9, "package://x")
    assert set(fg.OPS) == set(fg.CLIENT_OPS)
    for cls in fg.OPS.values():
        assert cls.LISTS is None or cls.LISTS in {f.name for f in dataclasses.fields(cls)}
    with pytest.raises(fg.FoxgloveError, match="channelId"):
        fg.parse_op('{"op": "subscribe", "subscriptions": [{"id": 1}]}')


def test_too_many_entries_is_refused():
    frame = json.dumps({"op": "unsubscribe", "subscriptionIds": list(range(fg.MAX_ITEMS + 1))})
    with pytest.raises(fg.FoxgloveError, match="at most"):
        fg.parse_text(frame)


def test_parameters_round_trip_through_their_wire_types():
    assert fg.param_to_wire("/b", b"\x01\x02") == {"name": "/b", "value": "AQI=",
                                                   "type": "byte_array"}
    assert fg.param_from_wire({"value": "AQI=", "type": "byte_array"}) == [1, 2]
    assert fg.param_to_wire("/f", 1.5)["type"] == "float64"
    assert fg.param_to_wire("/l", [1.0, 2.0])["type"] == "float64_array"
    assert fg.param_from_wire({"value": 3, "type": "float64"}) == 3.0
    assert fg.param_to_wire("/s", "x") == {"name": "/s", "value": "x"}
    assert fg.param_from_wire({"value": None}) is None


def test_binary_client_message_and_service_call():
    msg = fg.parse_binary(struct.pack("<BI", 1, 9) + b"abc")
    assert msg == fg.ClientMessage(9, b"abc")
    call = fg.parse_binary(struct.pack("<BIII", 2, 4, 77, 3) + b"cdr" + b"\x00\x01")
    assert call == fg.ServiceCallRequest(4, 77, "cdr", b"\x00\x01")


@pytest.mark.parametrize(
    ("frame", "words"),
    [
        (b"", "empty"),
        (b"\x09abc", "unknown opcode 9"),
        (b"\x01\x00", "shorter than its header"),
        (b"\x02\x00\x00\x00\x00", "shorter than its header"),
        (struct.pack("<BIII", 2, 1, 1, 1_000_000) + b"cdr", "encoding length"),
        (struct.pack("<BIII", 2, 1, 1, 2) + b"\xff\xfe", "UTF-8"),
    ],
)
def test_bad_binary_frames_name_the_problem(frame, words):
    with pytest.raises(fg.FoxgloveError) as info:
        fg.parse_binary(frame)
    assert words in str(info.value)


def test_server_binary_frames_have_the_spec_layout():
    data = fg.message_data(5, 1_700_000_000_123_456_789, b"CDR")
    assert data[0] == 1 and struct.unpack_from("<IQ", data, 1) == (5, 1_700_000_000_123_456_789)
    assert data[13:] == b"CDR"
    assert fg.time(42) == struct.pack("<BQ", 2, 42)
    resp = fg.service_call_response(3, 9, "cdr", b"\x00\x01")
    assert struct.unpack_from("<BIII", resp) == (3, 3, 9, 3) and resp[13:] == b"cdr\x00\x01"
    assert fg.nanoseconds(1.5) == 1_500_000_000 and fg.nanoseconds(-1.0) == 0


def test_ros2_schema_renames_only_field_names_ros2_forbids():
    text = ("uint8 ADD=1\nuint8 maskAction\nstring mapLayer \"x\"\nfloat64[9] K\nint32 ok_name\n"
            "====\nMSG: map_messages/Point\nfloat64 x\n")
    assert fg.ros2_schema(text) == (
        "uint8 ADD=1\nuint8 mask_action\nstring map_layer \"x\"\nfloat64[9] k\nint32 ok_name\n"
        "====\nMSG: map_messages/Point\nfloat64 x\n")


def test_service_description_carries_both_schema_spellings():
    desc = fg.service(4, "/s", "std_srvs/srv/Trigger", ("std_srvs/srv/Trigger_Request", ""),
                      ("std_srvs/srv/Trigger_Response", "bool success\nstring message\n"))
    assert desc["request"]["schemaName"] == "std_srvs/srv/Trigger_Request"
    assert desc["response"]["schemaEncoding"] == "ros2msg"
    assert desc["responseSchema"] == "bool success\nstring message\n"


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner,
                                                               max_size=4),
    max_leaves=12,
)


@settings(max_examples=400, deadline=None, derandomize=True)
@given(
    op=st.sampled_from([*fg.CLIENT_OPS, "nope"]),
    fields=st.dictionaries(
        st.sampled_from(["subscriptions", "subscriptionIds", "channels", "channelIds",
                         "parameterNames", "parameters", "id", "uri", "requestId", "x"]),
        json_values, max_size=4,
    ),
)
def test_fuzzed_text_ops_only_raise_protocol_errors(op, fields):
    try:
        text = json.dumps({"op": op, **fields})
    except ValueError:
        return
    try:
        parsed = fg.parse_text(text)
    except fg.FoxgloveError as exc:
        assert str(exc)
    else:
        assert parsed["op"] == op
        assert isinstance(fg.client_op(parsed), fg.OPS[op])


@settings(max_examples=400, deadline=None, derandomize=True)
@given(st.binary(max_size=64))
def test_fuzzed_binary_frames_only_raise_protocol_errors(data):
    try:
        fg.parse_binary(data)
    except fg.FoxgloveError as exc:
        assert str(exc)

"""Status levels, the set_level op, and rendering errors as status ops."""

import pytest

from hitrobot_server.protocol.errors import (
    DEFAULT_LEVEL,
    LEVELS,
    ProtocolError,
    message_id,
    set_level,
    should_send,
    status_op,
)

# client level -> message levels it receives
RECEIVES = {
    "info": {"info", "warning", "error"},
    "warning": {"warning", "error"},
    "error": {"error"},
    "none": set(),
}


@pytest.mark.parametrize("client", LEVELS)
@pytest.mark.parametrize("message", ["info", "warning", "error", "none"])
def test_should_send(client, message):
    assert should_send(client, message) is (message in RECEIVES[client])


def test_levels_and_default():
    assert LEVELS == ("info", "warning", "error", "none")
    assert DEFAULT_LEVEL == "error"


@pytest.mark.parametrize(("client", "message"), [("debug", "error"), ("error", "fatal")])
def test_unknown_levels_are_programming_errors(client, message):
    with pytest.raises(ValueError, match="unknown status level"):
        should_send(client, message)


@pytest.mark.parametrize("level", LEVELS)
def test_set_level_returns_new_level(level):
    assert set_level({"op": "set_level", "level": level}) == level


@pytest.mark.parametrize("level", ["debug", "ERROR", "", None, 2])
def test_set_level_bad_level_is_reported(level):
    with pytest.raises(ProtocolError) as info:
        set_level({"op": "set_level", "level": level, "id": "lvl-1"})
    assert "set_level: field 'level' must be one of 'info', 'warning', 'error', 'none'" in (
        info.value.msg
    )
    assert info.value.id == "lvl-1"


def test_status_op_omits_missing_id():
    assert status_op("warning", "careful") == {"op": "status", "level": "warning", "msg": "careful"}
    assert status_op("error", "bad", 0) == {"op": "status", "level": "error", "msg": "bad", "id": 0}


def test_protocol_error_renders_as_status():
    err = ProtocolError("subscribe: missing required field 'topic'", "sub-1")
    assert str(err) == err.msg
    assert err.level == "error"
    assert err.to_status() == {
        "op": "status",
        "level": "error",
        "msg": "subscribe: missing required field 'topic'",
        "id": "sub-1",
    }
    assert "id" not in ProtocolError("x").to_status()
    assert ProtocolError("x", level="warning").to_status()["level"] == "warning"


@pytest.mark.parametrize(
    ("obj", "expected"),
    [
        ({"id": "a"}, "a"),
        ({"id": 0}, 0),
        ({"id": True}, None),
        ({"id": 1.0}, None),
        ({"id": None}, None),
        ({}, None),
        (["id"], None),
    ],
)
def test_message_id_trusts_only_strings_and_integers(obj, expected):
    assert message_id(obj) == expected

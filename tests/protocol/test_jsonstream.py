"""Splitting a TCP byte stream into JSON objects, with recovery from broken input."""

import orjson
import pytest

from hitrobot_server.protocol.errors import ProtocolError
from hitrobot_server.protocol.jsonstream import JsonStreamDecoder

MESSAGE = {"op": "publish", "topic": "/chatter", "msg": {"data": 'café 中文 😀 {}"\\'}}
ENCODED = orjson.dumps(MESSAGE)
TRICKY = b'{"s":"}{\\"{","t":"\\\\","u":"\\u00e9"}'


def errors(values):
    return [v for v in values if isinstance(v, ProtocolError)]


def test_single_object():
    assert JsonStreamDecoder().feed(ENCODED) == [MESSAGE]


@pytest.mark.parametrize("payload", [ENCODED, TRICKY])
def test_split_at_every_byte_position(payload):
    expected = orjson.loads(payload)
    for i in range(len(payload) + 1):
        decoder = JsonStreamDecoder()
        assert decoder.feed(payload[:i]) + decoder.feed(payload[i:]) == [expected], i
        assert decoder.buffered == 0


def test_byte_by_byte():
    decoder = JsonStreamDecoder()
    values = []
    for byte in ENCODED + b"\n" + TRICKY:
        values += decoder.feed(bytes([byte]))
    assert values == [MESSAGE, orjson.loads(TRICKY)]


def test_braces_and_escaped_quotes_inside_strings():
    assert JsonStreamDecoder().feed(TRICKY) == [{"s": '}{"{', "t": "\\", "u": "é"}]


def test_concatenated_and_newline_separated_mixed():
    stream = b'{"a":1}{"b":2}\n{"c":3}\r\n  \t{"d":{"e":[{"f":4}]}}\n\n'
    assert JsonStreamDecoder().feed(stream) == [
        {"a": 1},
        {"b": 2},
        {"c": 3},
        {"d": {"e": [{"f": 4}]}},
    ]


def test_pretty_printed_objects():
    pretty = (
        b'{\n  "op": "publish",\n  "msg": {\n    "poses": [\n      {\n        "x": 1\n'
        b"      }\n    ]\n  }\n}\n"
    )
    assert JsonStreamDecoder().feed(pretty) == [{"op": "publish", "msg": {"poses": [{"x": 1}]}}]


def test_garbage_between_objects_is_reported_and_skipped():
    values = JsonStreamDecoder().feed(b'{"a":1} garbage {"b":2}\nhello\n{"c":3}]')
    assert [v for v in values if not isinstance(v, ProtocolError)] == [
        {"a": 1},
        {"b": 2},
        {"c": 3},
    ]
    kinds = [type(v) for v in values]
    assert kinds == [dict, ProtocolError, dict, ProtocolError, dict, ProtocolError]
    assert "expected a JSON object, got 'garbage '" in values[1].msg
    assert values[1].msg.startswith("invalid JSON: ")


def test_top_level_values_other_than_objects_are_rejected():
    values = JsonStreamDecoder().feed(b'"text"\n42\n{"ok":true}')
    assert values[-1] == {"ok": True}
    assert len(errors(values)) == 1  # one run of stray data before the object


def test_unterminated_string_ends_at_the_newline():
    # A raw newline cannot be inside a JSON string, so the object is reported broken and
    # decoding resumes with the next line.
    decoder = JsonStreamDecoder()
    values = decoder.feed(b'{"op":"publish","topic":"/a\n{"op":"ok"}\n')
    assert len(values) == 2
    assert isinstance(values[0], ProtocolError)
    assert "unterminated string" in values[0].msg
    assert values[1] == {"op": "ok"}
    assert decoder.buffered == 0


def test_missing_closing_brace_resyncs_at_next_object():
    values = JsonStreamDecoder().feed(b'{"op":"a"\n{"op":"b"}\n{"op":"c"}')
    assert isinstance(values[0], ProtocolError)
    assert "unexpected '{'" in values[0].msg
    assert values[1:] == [{"op": "b"}, {"op": "c"}]


def test_balanced_but_invalid_object_is_reported_in_its_place():
    values = JsonStreamDecoder().feed(b'{"a":1}{"b":tru}{"c":[1,]}{"d":4}')
    assert values[0] == {"a": 1}
    assert isinstance(values[1], ProtocolError) and isinstance(values[2], ProtocolError)
    assert values[3] == {"d": 4}


def test_invalid_utf8_is_an_error_for_that_object_only():
    values = JsonStreamDecoder().feed(b'{"a":"\xff\xfe"}{"b":2}')
    assert isinstance(values[0], ProtocolError)
    assert values[1] == {"b": 2}


def test_oversized_object_in_one_feed():
    decoder = JsonStreamDecoder(max_message_size=100)
    big = orjson.dumps({"data": "x" * 200})
    values = decoder.feed(big + b'{"ok":1}')
    assert len(values) == 2
    assert "larger than the limit of 100 bytes" in values[0].msg
    assert values[1] == {"ok": 1}


def test_oversized_object_across_feeds_is_discarded_with_bounded_memory():
    decoder = JsonStreamDecoder(max_message_size=100)
    reported = decoder.feed(b'{"data":[')
    for _ in range(100):
        reported += decoder.feed(b'{"k":"}}}"},' * 5)
        assert decoder.buffered < 200
    reported += decoder.feed(b'{}]}\n{"next":true}\n')
    assert len(reported) == 2
    assert "larger than the limit" in reported[0].msg
    assert reported[1] == {"next": True}


def test_object_at_the_size_limit_is_accepted():
    payload = orjson.dumps({"d": "x" * 50})
    assert JsonStreamDecoder(max_message_size=len(payload)).feed(payload) == [orjson.loads(payload)]


def test_empty_feed_and_whitespace_only():
    decoder = JsonStreamDecoder()
    assert decoder.feed(b"") == []
    assert decoder.feed(b" \r\n\t ") == []
    assert decoder.buffered == 0


def test_large_object_in_many_reads():
    msg = {"data": list(range(300_000)), "s": "é" * 1000}
    payload = orjson.dumps({"op": "publish", "msg": msg})
    decoder = JsonStreamDecoder()
    values = []
    for start in range(0, len(payload), 65536):
        values += decoder.feed(payload[start : start + 65536])
    assert values == [orjson.loads(payload)]

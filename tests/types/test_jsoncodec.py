"""Wire JSON: base64 for bytes, null for non-finite floats, numpy input, ASCII-only variant."""

from __future__ import annotations

import base64
import json
import math

import numpy as np
import orjson
import pytest

from hitrobot_server.types import jsoncodec
from hitrobot_server.types.jsoncodec import dumps, dumps_ascii, loads


def test_bytes_become_standard_base64() -> None:
    raw = bytes([0, 251, 255, 62, 63])
    out = json.loads(dumps({"data": raw, "ba": bytearray(b"\xff"), "mv": memoryview(b"ok")}))
    assert out == {"data": base64.b64encode(raw).decode(), "ba": "/w==", "mv": "b2s="}
    assert "+" in out["data"] or "/" in out["data"]


def test_non_finite_floats_become_null() -> None:
    out = dumps({"a": math.nan, "b": [1.5, math.inf, -math.inf]})
    assert out == b'{"a":null,"b":[1.5,null,null]}'


def test_numpy_arrays_and_scalars() -> None:
    value = {
        "f": np.array([1.0, np.nan], dtype=np.float32),
        "strided": np.arange(6, dtype=np.int64)[::2],
        "s": np.float64(2.5),
        "i": np.uint64(7),
        "wide": np.longdouble(0.5),
    }
    assert json.loads(dumps(value)) == {
        "f": [1.0, None],
        "strided": [0, 2, 4],
        "s": 2.5,
        "i": 7,
        "wide": 0.5,
    }


def test_unserialisable_raises() -> None:
    with pytest.raises(TypeError):
        dumps({"x": object()})


def test_dumps_ascii_escapes_everything_non_ascii() -> None:
    value = {"text": "héllo → 😀", "plain": "abc", "raw": b"\x01"}
    out = dumps_ascii(value)
    assert out.isascii()
    assert b"\\ud83d\\ude00" in out
    assert b"\\u00e9" in out and b"\\u2192" in out
    assert json.loads(out) == {"text": "héllo → 😀", "plain": "abc", "raw": "AQ=="}
    assert orjson.loads(out) == json.loads(out)


def test_dumps_ascii_is_dumps_for_ascii_input() -> None:
    value = {"a": [1, 2.5, None], "b": "x"}
    assert dumps_ascii(value) == dumps(value)


def test_loads_accepts_text_and_bytes() -> None:
    assert loads(b'{"a":[1,2]}') == {"a": [1, 2]}
    assert loads('{"b":"\\u00e9"}') == {"b": "é"}
    with pytest.raises(ValueError):
        loads(b"{nope")


def test_loads_accepts_python_nan_and_infinity_literals():
    import math

    from hitrobot_server.types import jsoncodec

    value = jsoncodec.loads(b'{"a": NaN, "b": -Infinity, "c": [Infinity]}')
    assert math.isnan(value["a"]) and value["b"] == -math.inf and value["c"] == [math.inf]
    with pytest.raises(ValueError):
        jsoncodec.loads(b'{"a": nope}')


# --- values the server cannot carry --------------------------------------------------------


@pytest.mark.parametrize(
    ("value", "needle"),
    [
        ({"id": "a", "msg": {"name": "x\ud800"}}, "field 'msg.name' is not valid Unicode"),
        ({"id": "a", "k": [1, 2**64]}, "field 'k[1]' is an integer outside the 64-bit range"),
        ({"id": "a", "k": -(2**63) - 1}, "field 'k'"),
        ({"id": "a", "k\udfff": 1}, "has a key that is not a valid Unicode string"),
        ({"id": "a", "k": {1: 2}}, "has a key"),
        ({"id": "a", "k": b"raw"}, "unsupported type (bytes)"),
        ({"id": "a", "k": {1, 2}}, "unsupported type (set)"),
    ],
)
def test_check_value_refuses_and_names_the_field_not_the_value(value, needle):
    with pytest.raises(jsoncodec.InvalidValue) as info:
        jsoncodec.check_value(value)
    assert needle in str(info.value)
    assert info.value.id == "a"
    assert "\ud800" not in str(info.value) and str(2**64) not in str(info.value)


def test_check_value_accepts_the_widest_ros_values_and_bounds_depth():
    ok = {"u64": 2**64 - 1, "i64": -(2**63), "f": [math.nan, math.inf], "s": "ok😀",
          "n": None, "b": True}
    jsoncodec.check_value(ok)
    jsoncodec.check_value({"raw": b"\x00\xff"}, allow_bytes=True)
    deep: list = []
    for _ in range(50):
        deep = [deep]
    jsoncodec.check_value(deep, max_depth=51)
    with pytest.raises(jsoncodec.InvalidValue, match="deeper than 20"):
        jsoncodec.check_value({"id": 7, "d": deep}, max_depth=20)
    # iterative: far deeper than Python's recursion limit costs no stack
    for _ in range(5000):
        deep = [deep]
    with pytest.raises(jsoncodec.InvalidValue):
        jsoncodec.check_value(deep)


def test_loads_fallback_checks_values_and_tags_the_op_id():
    with pytest.raises(jsoncodec.InvalidValue) as info:
        jsoncodec.loads('{"id": 5, "x": NaN, "s": "a\\ud800"}')
    assert info.value.id == 5
    with pytest.raises(jsoncodec.InvalidValue) as info:
        jsoncodec.loads('{"id": 123456789012345678901234, "x": NaN}')
    assert info.value.id is None and "'id'" in str(info.value)
    assert math.isnan(jsoncodec.loads('{"x": NaN}')["x"])

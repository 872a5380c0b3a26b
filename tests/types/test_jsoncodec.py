"""Wire JSON: base64 for bytes, null for non-finite floats, numpy input, ASCII-only variant."""

from __future__ import annotations

import base64
import json
import math

import numpy as np
import orjson
import pytest

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

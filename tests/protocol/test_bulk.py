"""The whole-op codecs the worker process runs for big messages."""

from __future__ import annotations

import numpy as np
import pytest

from hitrobot_server.protocol import bulk
from hitrobot_server.session.rosbridge.verbatim import verbatim_publish


def test_long_plain_numeric_lists_become_the_smallest_array_that_holds_them():
    n = bulk.COMPACT_MIN
    obj = {"a": [-1, 0, 100] * n, "b": {"c": [70000] * n}, "d": [{"e": [0.5] * n}],
           "f": [2**40] * n}
    out = bulk.compact_arrays(obj)
    assert out["a"].dtype == np.int8 and out["a"].tolist() == [-1, 0, 100] * n
    assert out["b"]["c"].dtype == np.int32
    assert out["d"][0]["e"].dtype == np.float64
    assert out["f"].dtype == np.int64


@pytest.mark.parametrize("items", [
    [True, False],  # bools are not numbers for the converter
    [1, 2.5],  # mixed: the converter decides per field
    [1, None],
    ["1", 2],
    [2**64, 1],  # beyond int64: exact Python ints are kept
])
def test_lists_numpy_cannot_hold_exactly_stay_lists(items):
    value = items * bulk.COMPACT_MIN
    assert bulk.compact_arrays({"x": value})["x"] == value


def test_short_lists_stay_lists():
    assert bulk.compact_arrays([1, 2, 3]) == [1, 2, 3]


def test_decode_errors_are_short_and_picklable():
    with pytest.raises(bulk.DecodeError, match="unexpected|invalid|Expected|EOF"):
        bulk.decode_json('{"op": "publish", ' + " " * 1000)
    with pytest.raises(bulk.PngError):
        bulk.decode_png("not base64 png")
    assert bulk.decode_json('{"x": NaN}')["x"] != 0  # the NaN literal fallback still applies


def _op(text: str) -> dict:
    import orjson
    return orjson.loads(text)


def test_verbatim_publish_reuses_the_clients_text():
    text = '{"op":"publish","topic":"/s","msg":{"data":"x","n":[1.5,2.5]}}'
    assert verbatim_publish(text, _op(text)) == text.encode()
    roslibjs = '{"op":"publish","id":"publish:/s:7","topic":"/s","msg":{"data":"x"},"latch":false}'
    assert verbatim_publish(roslibjs, _op(roslibjs)) == (
        b'{"op":"publish","topic":"/s","msg":{"data":"x"}}')


@pytest.mark.parametrize("text", [
    '{"op": "publish", "topic": "/s", "msg": {"data": "x"}}',  # spaced: not our serialisation
    '{"op":"publish","topic":"/s","msg":{"data":"x"},"latch":false }',
    '{"op":"publish","topic":"/s","msg":{"d":NaN}}',  # only the lenient parser reads NaN
    '{"op":"publish","topic":"/s","msg":{"d":-Infinity}}',
    '{"op":"publish","topic":"/s","msg":{"data":"x"},"topic":"/other"}',
])
def test_verbatim_publish_refuses_text_it_cannot_vouch_for(text):
    import json
    assert verbatim_publish(text, json.loads(text)) is None


def test_duplicate_keys_still_read_as_what_was_validated():
    import json
    text = '{"op":"publish","topic":"/s","msg":{"data":"old"},"msg":{"data":"new"}}'
    out = verbatim_publish(text, _op(text))
    assert json.loads(out) == {"op": "publish", "topic": "/s", "msg": {"data": "new"}}


def test_decode_error_keeps_its_id_through_pickling():
    import pickle
    error = pickle.loads(pickle.dumps(bulk.DecodeError("bad value", "op7")))
    assert isinstance(error, bulk.DecodeError) and error.id == "op7" and str(error) == "bad value"

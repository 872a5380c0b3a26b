"""The parameter store checks values like messages: size and nesting depth (counted from the
root, so the whole tree always encodes), a bound on the whole tree, and no recursion."""

from __future__ import annotations

import orjson
import pytest

from hitrobot_server.bus.params import (
    MAX_DEPTH,
    MAX_TOTAL_BYTES,
    MAX_VALUE_BYTES,
    ParamError,
    ParamStore,
    json_depth,
)


def nested(depth: int) -> str:
    return "[" * depth + "]" * depth


@pytest.mark.parametrize(("text", "depth"), [
    (b"3", 0), (b'"[[{"', 0), (b"[]", 1), (b'[1,"]]]",{"a":[{}]}]', 4),
    (b'["\\"[[", [[]]]', 3), (b'{"k\\\\":[[]]}', 3),
])
def test_json_depth_skips_brackets_inside_strings(text, depth):
    assert json_depth(text) == depth


def test_a_value_too_deep_for_its_name_is_refused_and_the_tree_still_encodes():
    store = ParamStore()
    store.set("/keep", 1)
    store.set_json("/a", nested(MAX_DEPTH - 1))  # one name segment + 99 levels: at the limit
    with pytest.raises(ParamError, match="nested 101 levels"):
        store.set_json("/a/b", nested(MAX_DEPTH - 1))
    with pytest.raises(ParamError, match="nested"):
        store.set_json("/x", nested(400))
    with pytest.raises(ParamError, match="nested"):
        store.set("/" + "/".join(["n"] * MAX_DEPTH), {"v": 1})
    assert orjson.loads(store.get_json("/"))["keep"] == 1
    assert store.get("/a") == orjson.loads(nested(MAX_DEPTH - 1))
    assert not store.has("/x") and store.names() == ["/a", "/keep"]


def test_a_value_too_big_is_refused_before_it_is_parsed_and_changes_nothing():
    store = ParamStore()
    store.set("/v", "old")
    with pytest.raises(ParamError, match=f"limit of {MAX_VALUE_BYTES}"):
        store.set_json("/v", "[" + "[]," * MAX_VALUE_BYTES + "[]]")
    with pytest.raises(ParamError, match="limit"):
        store.set_json("/v", '"' + "\u00e9" * (MAX_VALUE_BYTES // 2 + 1) + '"')  # 2 bytes each
    assert store.get("/v") == "old"


def test_the_whole_tree_is_bounded_and_bytes_come_back_when_values_go():
    store = ParamStore()
    chunk = "x" * (MAX_VALUE_BYTES - 10)
    count = MAX_TOTAL_BYTES // MAX_VALUE_BYTES
    for i in range(count):
        store.set(f"/ns/v{i}", chunk)
    with pytest.raises(ParamError, match="would hold"):
        store.set("/extra", chunk)
    assert not store.has("/extra")
    store.set("/ns/v0", chunk)  # replacing a value does not count it twice
    store.set("/ns/v1", 1)  # a smaller value frees its bytes
    store.set("/extra", chunk)
    store.delete("/ns")  # deleting a namespace frees everything set under it
    assert store.total_bytes == len(orjson.dumps(chunk)) + len("extra")  # texts and names
    store.set("/", {"a": {"b": 1}})
    assert store.total_bytes == len("a") + len("b") + len(b"1")
    store.set("/a", 5)  # the namespace is replaced by a value
    assert store.names() == ["/a"] and store.total_bytes == 2
    store.set("/a/b/c", [1])  # and the value by a namespace again
    assert store.get("/") == {"a": {"b": {"c": [1]}}} and store.total_bytes == 6
    assert store.get_json("/") == b'{"a":{"b":{"c":[1]}}}'


def test_dictionary_values_become_names_and_keep_no_python_objects():
    store = ParamStore()
    store.set_json("/cfg", b'{"speed": 0.5, "limits": {"max": [1, 2]}, "empty": {}}')
    assert store.get("/cfg/limits/max") == [1, 2]
    assert store.names() == ["/cfg/empty", "/cfg/limits/max", "/cfg/speed"]
    assert orjson.loads(store.get_json("/cfg")) == {"speed": 0.5, "limits": {"max": [1, 2]},
                                                    "empty": {}}
    store.set_json("/big", "[" + "[]," * 1000 + "[]]")
    assert isinstance(store._node("/big"), bytes)  # one text, not 1001 lists


def test_root_and_non_json_values_are_refused():
    store = ParamStore()
    with pytest.raises(ParamError, match="dictionary"):
        store.set_json("/", "[]")
    with pytest.raises(ParamError, match="not a JSON value"):
        store.set("/s", {1, 2})
    with pytest.raises(orjson.JSONDecodeError):
        store.set_json("/t", "[")
    assert store.names() == []


def test_wide_trees_are_walked_without_recursion():
    store = ParamStore()
    deep = "/" + "/".join(f"n{i}" for i in range(MAX_DEPTH - 1))
    store.set(deep, 1)
    assert store.names() == [deep]
    store.set_json("/wide", orjson.dumps({f"k{i}": {"v": i} for i in range(5000)}))
    assert len(store.names()) == 5001
    store.set("/wide", 0)
    assert len(store.names()) == 2

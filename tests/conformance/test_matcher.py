"""The vector pattern matcher: subset semantics, every ``$`` operator, and pattern checking."""

from __future__ import annotations

import pytest

from hitrobot_server.conformance.matcher import PatternError, check_pattern, match
from hitrobot_server.conformance.runner import TypedArray


def ok(pattern, value) -> bool:
    return match(pattern, value) is None


class TestSubset:
    def test_objects_match_as_a_recursive_subset(self):
        value = {"op": "publish", "topic": "/t", "msg": {"data": "x", "extra": 1}}
        assert ok({"op": "publish", "msg": {"data": "x"}}, value)
        assert ok({}, value)

    def test_missing_key_is_reported_with_its_path(self):
        reason = match({"msg": {"data": "x"}}, {"msg": {}})
        assert reason == "$.msg.data: missing"

    def test_different_scalar_is_reported_with_both_values(self):
        reason = match({"a": [1, {"b": "x"}]}, {"a": [1, {"b": "y"}]})
        assert reason == "$.a[1].b: expected 'x', got 'y'"

    def test_lists_match_element_wise_and_by_length(self):
        assert ok([1, {"a": 1}], [1, {"a": 1, "b": 2}])
        assert not ok([1, 2], [1, 2, 3])
        assert not ok([1, 2], [2, 1])
        assert not ok([1], {"0": 1})

    def test_object_pattern_needs_an_object(self):
        assert match({"a": 1}, [1]) == "$: expected an object, got [1]"

    def test_numbers_compare_by_value_but_booleans_are_not_numbers(self):
        assert ok(1, 1.0)
        assert ok(0.5, 0.5)
        assert not ok(1, True)
        assert not ok(True, 1)
        assert not ok(0, False)
        assert ok(False, False)

    def test_null_and_strings_are_exact(self):
        assert ok(None, None)
        assert not ok(None, 0)
        assert not ok("1", 1)
        assert not ok(1, "1")


class TestOperators:
    def test_any_accepts_every_present_value_but_not_a_missing_key(self):
        assert ok({"a": {"$any": True}}, {"a": None})
        assert not ok({"a": {"$any": True}}, {})

    def test_absent(self):
        assert ok({"id": {"$absent": True}}, {"op": "x"})
        assert match({"id": {"$absent": True}}, {"id": 3}) == "$.id: must be absent, got 3"
        assert not ok({"$absent": True}, 1)

    @pytest.mark.parametrize(
        ("name", "good", "bad"),
        [
            ("string", "s", 1),
            ("number", 1.5, "1"),
            ("number", 2, True),
            ("integer", 2, 2.0),
            ("integer", -3, False),
            ("boolean", False, 0),
            ("object", {}, []),
            ("array", [], {}),
            ("array", TypedArray([1.0]), b""),
            ("null", None, 0),
            ("bytes", b"\x01", "AQ=="),
        ],
    )
    def test_type(self, name, good, bad):
        assert ok({"$type": name}, good)
        assert not ok({"$type": name}, bad)

    def test_regex_searches_strings_only(self):
        assert ok({"$regex": "(?i)invalid json"}, "Invalid JSON: line 1")
        assert ok({"$regex": "^a.c$"}, "abc")
        assert not ok({"$regex": "^a.c$"}, "abcd")
        assert not ok({"$regex": "1"}, 1)

    def test_contains_is_a_substring_for_strings(self):
        assert ok({"$contains": "topic"}, "missing required field 'topic'")
        assert not ok({"$contains": "topic"}, "missing field 'type'")
        assert not ok({"$contains": 1}, "1")

    def test_contains_matches_some_item_of_a_list(self):
        assert ok({"$contains": "/a"}, ["/b", "/a"])
        assert ok({"$contains": {"type": "x"}}, [{"type": "y"}, {"type": "x", "n": 1}])
        assert not ok({"$contains": "/a"}, ["/ab"])
        assert not ok({"$contains": "a"}, {"a": 1})

    def test_len(self):
        assert ok({"$len": 2}, "ab")
        assert ok({"$len": 2}, [1, 2])
        assert ok({"$len": 1}, {"k": 1})
        assert ok({"$len": 3}, b"abc")
        assert not ok({"$len": 2}, [1])
        assert not ok({"$len": 1}, 5)

    def test_in_matches_any_option(self):
        assert ok({"$in": [1, 2, {"$type": "string"}]}, "x")
        assert ok({"$in": [1, 2]}, 2)
        assert not ok({"$in": [1, 2]}, 3)

    def test_not(self):
        assert ok({"$not": {"$contains": "/a"}}, ["/b"])
        assert not ok({"$not": {"$contains": "/a"}}, ["/a"])

    def test_gt_and_lt_need_numbers(self):
        assert ok({"$gt": 1, "$lt": 3}, 2)
        assert not ok({"$gt": 2}, 2)
        assert not ok({"$lt": 2}, 2)
        assert not ok({"$gt": 0}, True)
        assert not ok({"$gt": 0}, "5")

    def test_tag_checks_the_typed_array_tag(self):
        array = TypedArray([1.5, 2.0])
        array.cbor_tag = 85
        assert ok({"$tag": 85, "$match": [1.5, 2.0]}, array)
        assert not ok({"$tag": 86}, array)
        assert not ok({"$tag": 85}, [1.5, 2.0])

    def test_match_combines_a_literal_with_other_operators(self):
        pattern = {"$match": {"op": "publish"}, "$len": 1}
        assert ok(pattern, {"op": "publish"})
        assert not ok(pattern, {"op": "publish", "id": 1})

    def test_all_operators_of_an_object_must_hold(self):
        pattern = {"$type": "string", "$regex": "^a", "$len": 2}
        assert ok(pattern, "ab")
        assert not ok(pattern, "abc")
        assert not ok(pattern, "ba")


class TestCapture:
    def test_captured_values_are_stored_on_success(self):
        found: dict = {}
        pattern = {"id": {"$regex": "^service_request:", "$capture": "req"}, "n": {"$capture": "n"}}
        assert match(pattern, {"id": "service_request:/s:1", "n": 3}, found) is None
        assert found == {"req": "service_request:/s:1", "n": 3}

    def test_nothing_is_stored_when_the_match_fails_later(self):
        found: dict = {}
        pattern = {"a": {"$capture": "a"}, "b": 2}
        assert match(pattern, {"a": 1, "b": 3}, found) is not None
        assert found == {}


class TestCheckPattern:
    def test_valid_pattern_returns_its_captures(self):
        pattern = {"a": [{"$capture": "x"}], "b": {"$match": {"c": {"$capture": "y"}}}}
        assert sorted(check_pattern(pattern)) == ["x", "y"]

    @pytest.mark.parametrize(
        ("pattern", "complaint"),
        [
            ({"$type": "string", "plain": 1}, "mixes operators"),
            ({"$nope": 1}, "unknown operator"),
            ({"$regex": "("}, "bad regular expression"),
            ({"$regex": 1}, "must be a string"),
            ({"$type": "float"}, "type must be one of"),
            ({"$any": False}, "must be true"),
            ({"$absent": True, "$type": "null"}, "cannot be combined"),
            ({"$len": "2"}, "must be an integer"),
            ({"$tag": True}, "must be an integer"),
            ({"$gt": "1"}, "must be a number"),
            ({"$capture": "not an identifier"}, "identifier"),
            ({"$in": []}, "non-empty list"),
            ({"$in": [{"$capture": "x"}]}, "cannot capture"),
            ({"$not": {"$capture": "x"}}, "cannot capture"),
            ({"$contains": {"$capture": "x"}}, "cannot capture"),
            ({"a": {"$bad": 1}}, "$.a.$bad"),
        ],
    )
    def test_malformed_patterns_are_rejected(self, pattern, complaint):
        with pytest.raises(PatternError) as info:
            check_pattern(pattern)
        assert complaint in str(info.value)

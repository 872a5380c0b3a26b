"""The shipped vector files are well-formed, and the loader rejects malformed ones."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest

from hitrobot_server.conformance.runner import (
    STEP_FIELDS,
    VectorError,
    check_case,
    load_cases,
    load_file,
    step_kind,
)

VECTORS = Path(__file__).resolve().parents[2] / "protocol" / "vectors"
FILES = sorted(VECTORS.glob("*.json"))
EXPECTED_FILES = {
    "actions.json",
    "cbor.json",
    "envelope.json",
    "fragments.json",
    "latch.json",
    "params.json",
    "png.json",
    "rosapi.json",
    "service_providers.json",
    "services.json",
    "status.json",
    "throttle.json",
    "topics.json",
}


def test_every_expected_file_is_present():
    assert {path.name for path in FILES} == EXPECTED_FILES


@pytest.mark.parametrize("path", FILES, ids=lambda path: path.name)
def test_file_parses_and_every_step_has_a_known_shape(path: Path):
    cases = load_file(path)
    assert cases, "a vector file without cases"
    for case in cases:
        for step in case.steps:
            assert step_kind(step) in STEP_FIELDS
        assert any(step_kind(step).startswith("expect") for step in case.steps), case.name


def test_case_names_are_unique_across_files():
    names = Counter(case.name for path in FILES for case in load_file(path))
    assert [name for name, count in names.items() if count > 1] == []
    assert len(load_cases(VECTORS)) == sum(names.values())


def test_every_case_runs_on_its_own_namespace():
    """Cases that create resources must name them under ${ns} so runs never collide."""
    for case in load_cases(VECTORS):
        for step in case.steps:
            sent = step.get("send", step.get("send_fragmented"))
            if isinstance(sent, dict) and sent.get("op") in (
                "advertise",
                "advertise_service",
                "advertise_action",
            ):
                name = sent.get("topic", sent.get("service", sent.get("action")))
                assert name.startswith("${ns"), f"{case.name}: {name}"


def _case(*steps, clients=("a",)) -> dict:
    return {"name": "t", "clients": list(clients), "steps": list(steps)}


@pytest.mark.parametrize(
    ("raw", "complaint"),
    [
        ([], "a case must be an object"),
        ({"clients": ["a"], "steps": [{"sleep_ms": 1}]}, "non-empty string 'name'"),
        ({"name": "t", "clients": ["a", "a"], "steps": [{"sleep_ms": 1}]}, "distinct names"),
        ({"name": "t", "clients": ["a"], "steps": []}, "non-empty list"),
        ({"name": "t", "clients": ["a"], "steps": [{"sleep_ms": 1}], "extra": 1}, "unknown field"),
        (_case({"client": "a"}), "exactly one of"),
        (_case({"client": "a", "send": {}, "expect": {}}), "exactly one of"),
        (_case({"client": "a", "send": {}, "within_ms": 5}), "unknown field"),
        (_case({"client": "b", "send": {"op": "x"}}), "unknown client 'b'"),
        (_case({"close": "z"}), "unknown client 'z'"),
        (_case({"client": "a", "send": "text"}), "'send' must be an object"),
        (_case({"client": "a", "send_raw": {}}), "'send_raw' must be a string"),
        (_case({"client": "a", "send_fragmented": {"op": "x"}}), "missing 'fragment_size'"),
        (_case({"client": "a", "send_fragmented": {"x": 1}, "fragment_size": 2}), "op object"),
        (_case({"client": "a", "expect": {}, "within_ms": 0}), "'within_ms' must be"),
        (_case({"client": "a", "expect": {}, "within_ms": True}), "'within_ms' must be"),
        (_case({"sleep_ms": 60_000}), "'sleep_ms' must be"),
        (_case({"client": "a", "expect": {"$bad": 1}}), "bad pattern"),
        (_case({"client": "a", "send": {"op": "x", "t": "${nope}"}}), "unknown placeholder"),
        (_case({"client": "a", "expect_none": {"id": {"$capture": "x"}}}), "cannot capture"),
        (_case({"client": "a", "send": {}, "note": 3}), "'note' must be a string"),
    ],
)
def test_malformed_cases_are_rejected(raw, complaint):
    with pytest.raises(VectorError) as info:
        check_case(raw, "test.json")
    assert complaint in str(info.value)


def test_captured_names_become_placeholders_for_later_steps_only():
    capture = {"client": "a", "expect": {"id": {"$capture": "req"}}}
    use = {"client": "a", "send": {"op": "service_response", "id": "${req}"}}
    check_case(_case(capture, use), "test.json")
    with pytest.raises(VectorError, match="unknown placeholder"):
        check_case(_case(use, capture), "test.json")


def test_loader_reports_duplicate_names_and_bad_files(tmp_path: Path):
    case = _case({"sleep_ms": 1})
    (tmp_path / "a.json").write_text(json.dumps({"cases": [case]}))
    (tmp_path / "b.json").write_text(json.dumps({"cases": [case]}))
    with pytest.raises(VectorError, match="duplicate case name 't'"):
        load_cases(tmp_path)
    (tmp_path / "b.json").write_text("[]")
    with pytest.raises(VectorError, match="'cases' list"):
        load_cases(tmp_path)
    (tmp_path / "b.json").write_text("{")
    with pytest.raises(VectorError, match="b.json"):
        load_cases(tmp_path)
    (tmp_path / "empty").mkdir()
    with pytest.raises(VectorError, match="no vector files"):
        load_cases(tmp_path / "empty")

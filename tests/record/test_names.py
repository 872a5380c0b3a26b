"""The one safe spelling of a recording's name (record/names.py, pure), and what
``/record/start`` does with a hostile one or a symlink planted under the recording's name."""

from __future__ import annotations

import os

import pytest

from hitrobot_server.record.names import MAX_NAME, recording_name
from tests.helpers import WsClient

DEFAULT = "rec-20261126-001500"


@pytest.mark.parametrize(("name", "expected"), [
    ("run", "run.mcap"),
    ("run.mcap", "run.mcap"),
    ("site_2.day-3", "site_2.day-3.mcap"),
    ("", f"{DEFAULT}.mcap"),
    ("x" * (MAX_NAME - 5), "x" * (MAX_NAME - 5) + ".mcap"),
])
def test_safe_names_are_kept(name, expected):
    assert recording_name(name, DEFAULT) == expected


@pytest.mark.parametrize(("name", "reason"), [
    ("two\nlines", "not '\\n'"),
    ("line\rbreak", "not '\\r'"),
    ("evil\u202egnp.mcap", "not '\\u202e'"),
    ("star*", "not '*'"),
    ("-rf", "must not start with '-'"),
    (".hidden", "must not start with '.'"),
    ("con", "device name ('con')"),
    ("CON.log", "device name ('CON')"),
    ("lpt1", "device name ('lpt1')"),
    ("%2e%2e", "not '%'"),
    ("a..b", "must not hold '..'"),
    ("..", "must not start with '.'"),
    ("../escape", "not '/'"),
    ("sub\\dir", "not '\\\\'"),
    ("nul\0byte", "not '\\x00'"),
    ("space name", "not ' '"),
    ("caf\u00e9", "not 'é'"),
    ("x" * MAX_NAME, f"longer than {MAX_NAME} characters"),
    (".mcap", "is empty"),
])
def test_unsafe_names_are_refused_with_the_reason(name, reason):
    with pytest.raises(ValueError, match="field 'name'") as refused:
        recording_name(name, DEFAULT)
    assert reason in str(refused.value), str(refused.value)


async def test_a_planted_symlink_is_not_followed_and_nothing_outside_is_written(
        make_server, tmp_path):
    folder = tmp_path / "recordings"
    folder.mkdir()
    outside = tmp_path / "outside"
    outside.mkdir()
    os.symlink(outside / "victim.mcap", folder / "trap.mcap")  # dangling: open would create it
    (outside / "kept.mcap").write_bytes(b"precious")
    os.symlink(outside / "kept.mcap", folder / "kept.mcap")
    server = await make_server(record_dir=str(folder))
    client = await WsClient.open(server.port)
    try:
        for name in ("trap", "kept", "star*", "-rf", "con", "two\nlines"):
            reply = await client.call("/record/start", {"name": name})
            assert not reply["result"] and "success" not in reply["values"], (name, reply)
            status = await client.expect(op="status", id=reply["id"])
            assert status["level"] == "error", status
        assert server.recording.recorder is None
    finally:
        await client.close()
    assert sorted(p.name for p in outside.iterdir()) == ["kept.mcap"]
    assert (outside / "kept.mcap").read_bytes() == b"precious"
    assert sorted(p.name for p in folder.iterdir()) == ["kept.mcap", "trap.mcap"]
    assert all(p.is_symlink() for p in folder.iterdir())

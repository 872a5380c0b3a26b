"""The tokens file and ``hitrobot-server token`` (issue 47 items 1 and 7): only hashes on disk,
0600, atomic; the server's book sees changes without a restart and keeps its last good table
when the file is damaged."""

from __future__ import annotations

import json
import logging
import os
import stat
import subprocess
import sys
import time

import pytest

from hitrobot_server.commands.tokens import expiry
from hitrobot_server.state.tokens import (
    TokenBook,
    TokenFileError,
    add_token,
    read_table,
    revoke_token,
    token_hash,
    tokens_path,
)


def cli(*args: str, state) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "hitrobot_server", "token", *args,
                           "--state-dir", str(state)], capture_output=True, text=True,
                          timeout=60)


def test_add_prints_the_token_once_and_keeps_only_its_hash(tmp_path):
    out = cli("add", "alice", "--role", "operator", "--expires", "12h", state=tmp_path)
    assert out.returncode == 0, out.stderr
    token = out.stdout.strip()
    assert len(token) >= 40 and "alice" in out.stderr
    path = tokens_path(tmp_path)
    raw = path.read_text()
    assert token not in raw and token_hash(token) in raw
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o600
    assert not list(tmp_path.glob(".*tmp"))  # written through a temporary file, renamed
    (entry,) = json.loads(raw)["tokens"]
    assert entry["name"] == "alice" and entry["role"] == "operator"
    assert 11.9 * 3600 < entry["expires"] - entry["created"] < 12.1 * 3600


def test_the_first_token_before_any_server_makes_the_state_folders(tmp_path):
    """On a fresh machine neither $XDG_STATE_HOME nor its hitrobot-server folder exists yet."""
    env = {**os.environ, "XDG_STATE_HOME": str(tmp_path / "nothing" / "yet")}
    out = subprocess.run([sys.executable, "-m", "hitrobot_server", "token", "add", "tablet-1",
                          "--role", "operator"], capture_output=True, text=True, timeout=60,
                         env=env)
    assert out.returncode == 0, out.stderr
    folder = tmp_path / "nothing" / "yet" / "hitrobot-server"
    assert stat.S_IMODE(os.stat(folder).st_mode) == 0o700
    (entry,) = json.loads(tokens_path(folder).read_text())["tokens"]
    assert entry["name"] == "tablet-1" and entry["role"] == "operator"


def test_list_shows_no_secret_and_revoke_removes(tmp_path):
    token = cli("add", "bob", "--role", "viewer", state=tmp_path).stdout.strip()
    listed = cli("list", state=tmp_path)
    assert listed.returncode == 0
    (row,) = [json.loads(line) for line in listed.stdout.splitlines()]
    assert row["name"] == "bob" and row["role"] == "viewer" and row["expires"] is None
    assert token not in listed.stdout and token_hash(token) not in listed.stdout
    assert cli("revoke", "bob", state=tmp_path).returncode == 0
    assert cli("list", state=tmp_path).stdout == ""
    gone = cli("revoke", "bob", state=tmp_path)
    assert gone.returncode == 1 and "no token named 'bob'" in gone.stderr


@pytest.mark.parametrize(("args", "words"), [
    (("add", "x", "--role", "pilot"), "known roles are"),
    (("add", "x", "--role", "viewer", "--expires", "soon"), "give a duration"),
    (("add", "x", "--role", "viewer", "--expires", "2001-01-01"), "in the past"),
])
def test_bad_arguments_are_refused_with_the_reason(tmp_path, args, words):
    out = cli(*args, state=tmp_path)
    assert out.returncode == 1 and words in out.stderr
    assert not tokens_path(tmp_path).exists()


def test_a_role_of_the_roles_file_is_accepted(tmp_path):
    roles = tmp_path / "roles.json"
    roles.write_text('{"kiosk": {"permissions": ["read", "console"]}}')
    out = cli("add", "lobby", "--role", "kiosk", "--roles", str(roles), state=tmp_path)
    assert out.returncode == 0, out.stderr
    assert read_table(tokens_path(tmp_path))["lobby"].role == "kiosk"


def test_list_reports_a_damaged_file(tmp_path):
    tokens_path(tmp_path).write_text('{"tokens": [{"name": "x"}]}')
    out = cli("list", state=tmp_path)
    assert out.returncode == 1 and "damaged" in out.stderr and "#1" in out.stderr


def test_expiry_reads_durations_and_dates():
    assert expiry("90m", 1000.0) == 1000.0 + 5400
    assert expiry("2w", 0.0) == 14 * 86400
    assert expiry("2999-01-01T00:00+00:00", 0.0) > 3e10


def test_the_book_sees_adds_and_revokes_without_a_restart(tmp_path):
    path = tokens_path(tmp_path)
    clock = [0.0]
    book = TokenBook(path, clock=lambda: clock[0])
    assert book.lookup("nothing") == "unknown or revoked token"
    token = add_token(path, "carol", "admin", None)
    assert book.lookup(token) == "unknown or revoked token"  # looked less than a second ago
    clock[0] += 1.0
    assert book.lookup(token).name == "carol"
    revoke_token(path, "carol")
    clock[0] += 1.0
    assert book.lookup(token) == "unknown or revoked token"


def test_an_expired_token_is_refused_by_name(tmp_path):
    path = tokens_path(tmp_path)
    token = add_token(path, "temp", "viewer", time.time() + 0.5)
    book = TokenBook(path)
    assert book.lookup(token).name == "temp"
    assert book.lookup(token, now=time.time() + 1) == "token 'temp' expired"


def test_a_damaged_file_keeps_the_last_good_table_logged_once(tmp_path, caplog):
    path = tokens_path(tmp_path)
    token = add_token(path, "dave", "operator", None)
    clock = [0.0]
    book = TokenBook(path, clock=lambda: clock[0])
    caplog.set_level(logging.INFO, "hitrobot_server.state.tokens")
    for junk in ("{not json", "[1, 2]", "\xff\xfe"):
        path.write_text(junk, errors="surrogateescape")
        for _ in range(3):
            clock[0] += 1.0
            assert book.lookup(token).name == "dave"
    damaged = [r for r in caplog.records if "damaged" in r.getMessage()]
    assert len(damaged) == 3  # once per damage, not once per look
    assert token not in caplog.text
    with pytest.raises(TokenFileError):
        read_table(path)
    add_token(path.with_name("other.json"), "x", "viewer", None)
    os.replace(path.with_name("other.json"), path)  # repaired: the new table is used
    clock[0] += 1.0
    assert book.lookup(token) == "unknown or revoked token" and not book.damage


def test_a_huge_token_is_refused_before_it_is_hashed(tmp_path):
    book = TokenBook(tokens_path(tmp_path))
    assert "longer than" in book.lookup("x" * 65536)
